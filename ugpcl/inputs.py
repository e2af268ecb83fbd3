"""Files a scene reads (ear clipping's rings, star glow's image), checked before use: each check that fails is an
``InputError``, one line naming the parameter, the file and what is wrong with it. Sizes are read from the file
system and from the headers (a PNG's IHDR, a .npy's header) before anything is decoded, so a tiny file that
declares a huge image costs nothing.

A scene checks the file's existence and size in ``Params.check()`` (``check_file``), so a bad path is refused with
the other parameters, and reads the contents when it builds its state (a ``ParamError`` there).
"""

from __future__ import annotations

import functools
import json
import math
import os
import struct
from pathlib import Path
from tokenize import TokenError

import numpy as np


class InputError(ValueError):
    """A file named by a parameter that cannot be used: one line (``PARAM FILE: what is wrong``)."""


def shown(path) -> str:
    """The path as a message shows it: as given, or quoted where it holds what would break the line."""
    text = str(path)
    return text if text.isprintable() else repr(text)


def size_text(count: int) -> str:
    """Bytes as the messages give them: 1 KiB, 16 MiB, 2 GiB (exact units for the declared limits)."""
    for unit, shift in (("GiB", 30), ("MiB", 20), ("KiB", 10)):
        if count >= 1 << shift and count % (1 << shift) == 0:
            return f"{count >> shift} {unit}"
    return f"{count} bytes"


def check_file(name: str, path, max_bytes: int) -> Path:
    """``path`` as a Path when it is a readable, non-empty file of at most ``max_bytes``; InputError otherwise."""
    file = Path(path)
    where = f"{name} {shown(path)}"
    try:
        stat = file.stat()
    except FileNotFoundError:
        raise InputError(f"{where}: no such file") from None
    except OSError as err:
        raise InputError(f"{where}: cannot read it ({err.strerror})") from None
    if file.is_dir():
        raise InputError(f"{where}: is a folder, not a file")
    if not file.is_file():
        raise InputError(f"{where}: is not a regular file")
    if stat.st_size == 0:
        raise InputError(f"{where}: is empty")
    if stat.st_size > max_bytes:
        raise InputError(f"{where}: {stat.st_size} bytes is more than the limit of {size_text(max_bytes)}")
    if not os.access(file, os.R_OK):
        raise InputError(f"{where}: cannot read it (permission denied)")
    return file


def file_cached(maxsize: int):
    """Cache a reader ``reader(path, *args)`` by the file's version (inode, size, modification time) as well as its
    arguments: ``Params.check()`` reads and checks the file, the scene's reset takes the same result, and a file
    edited in between is read again. Errors are not cached. The arrays it returns are shared: treat them as
    read-only."""

    def wrap(reader):
        @functools.lru_cache(maxsize)
        def cached(version, path, *args):
            return reader(path, *args)

        @functools.wraps(reader)
        def read(path, *args):
            try:
                stat = os.stat(path)
                version = (stat.st_ino, stat.st_size, stat.st_mtime_ns)
            except (OSError, ValueError):
                version = None  # the reader says what is wrong
            return cached(version, str(path), *args)

        read.cache_clear = cached.cache_clear
        return read

    return wrap


def read_bytes(name: str, path, max_bytes: int) -> bytes:
    file = check_file(name, path, max_bytes)
    try:
        return file.read_bytes()
    except OSError as err:
        raise InputError(f"{name} {shown(path)}: cannot read it ({err.strerror})") from None


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text} is beyond float64")
    return value


def _no_constant(text: str):
    raise ValueError(f"{text} is not a finite number")


def read_json(name: str, path, max_bytes: int):
    """The JSON value of the file: UTF-8 text, finite numbers only (no NaN/Infinity, no 1e400)."""
    data = read_bytes(name, path, max_bytes)
    where = f"{name} {shown(path)}"
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise InputError(f"{where}: not UTF-8 text (byte {err.start})") from None
    try:
        return json.loads(text, parse_float=_finite, parse_constant=_no_constant)
    except json.JSONDecodeError as err:
        raise InputError(f"{where}: invalid JSON at line {err.lineno}, column {err.colno}: {err.msg}") from None
    except ValueError as err:  # a number parse_float refused, or an integer of more than 4300 digits
        raise InputError(f"{where}: invalid JSON number ({str(err).splitlines()[0]})") from None
    except RecursionError:
        raise InputError(f"{where}: JSON nested too deeply") from None


# {{{ images


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
NUMBER_KINDS = "fiu"
"""Image arrays hold floats or integers (not bools, complex numbers, objects or records)."""


def image_shape(name: str, path, max_side: int, max_bytes: int) -> tuple[int, int]:
    """(height, width) of a .png or .npy image from its header alone, after the checks of ``check_file``; each
    side 1 .. ``max_side``. A .npy must hold a float or integer (H, W, 3|4) array whose data the file holds whole."""
    file = check_file(name, path, max_bytes)
    where = f"{name} {shown(path)}"
    needed = 0
    with open(file, "rb") as f:
        if file.suffix.lower() == ".npy":
            (height, width, _), needed = _npy_header(f, where)
        else:
            head = f.read(24)
            if len(head) < 24 or head[:8] != PNG_SIGNATURE or head[12:16] != b"IHDR":
                raise InputError(f"{where}: not a PNG file (no PNG signature and IHDR header)")
            width, height = struct.unpack(">II", head[16:24])
    if not (1 <= width <= max_side and 1 <= height <= max_side):
        raise InputError(f"{where}: a {width}x{height} image; each side must be 1 to {max_side} pixels")
    if file.stat().st_size < needed:
        raise InputError(f"{where}: truncated ({file.stat().st_size} bytes, its header needs {needed})")
    return height, width


def _npy_header(f, where: str) -> tuple[tuple, int]:
    """(shape, bytes the file needs) of a .npy after checking its header's dtype and (H, W, 3|4) shape."""
    try:
        version = np.lib.format.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(f)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(f)
        else:
            raise ValueError(f"unsupported .npy version {version[0]}.{version[1]}")
    except (ValueError, SyntaxError, TokenError) as err:  # a damaged header fails to parse as a literal
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise InputError(f"{where}: not a .npy array ({reason})") from None
    if dtype.kind not in NUMBER_KINDS or dtype.fields is not None:
        raise InputError(f"{where}: holds {dtype} values; an image holds floats or integers")
    if len(shape) != 3 or shape[2] not in (3, 4):
        raise InputError(f"{where}: an array of shape {shape}; an image is (height, width, 3 or 4)")
    return shape, f.tell() + math.prod(shape) * dtype.itemsize


def read_image(name: str, path, max_side: int, max_bytes: int) -> np.ndarray:
    """A .png (values / 255) or .npy image as float32 (H, W, 4), top row first, alpha 1 where it has none; every
    value finite. The header is checked first (``image_shape``)."""
    height, width = image_shape(name, path, max_side, max_bytes)
    where = f"{name} {shown(path)}"
    if Path(path).suffix.lower() == ".npy":
        try:
            image = np.load(path, mmap_mode="r", allow_pickle=False).astype(np.float32)
        except (OSError, ValueError) as err:
            raise InputError(f"{where}: cannot read the array ({str(err).splitlines()[0]})") from None
    else:
        image = _decode_png(path, where)
    if image.shape[:2] != (height, width):
        raise InputError(f"{where}: decodes to {image.shape[1]}x{image.shape[0]}, its header says {width}x{height}")
    if image.shape[2] == 3:
        image = np.concatenate([image, np.ones((height, width, 1), np.float32)], axis=2)
    if not np.isfinite(image).all():
        raise InputError(f"{where}: holds NaN or inf")
    return image


def _decode_png(path, where: str) -> np.ndarray:
    import zlib
    from importlib.util import find_spec

    if find_spec("PIL") is None:
        raise InputError(f"{where}: reading a PNG needs Pillow (the render extra): pip install 'ugpcl[render]'")
    from PIL import Image

    try:
        with Image.open(path, formats=["PNG"]) as im:
            return np.asarray(im.convert("RGBA"), np.float32) / 255.0
    except (OSError, SyntaxError, ValueError, EOFError, zlib.error, Image.DecompressionBombError) as err:
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise InputError(f"{where}: cannot decode the PNG ({reason})") from None


# }}}
