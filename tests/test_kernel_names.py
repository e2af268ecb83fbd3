"""Every clkernels/*.cl file lists its kernels in its header, in host call order, and defines exactly those, in that
order (docs/conventions.md, "Kernel files"). No macro hides ``__kernel``, so one grep finds every kernel."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ugpcl.runtime import KERNEL_DIR

KERNEL_FILES = sorted(KERNEL_DIR.glob("*.cl"))

NAME = r"[A-Za-z_]\w*"
# A kernel entry of the header's list: indentation, an optional step number ("1.", "2b."), one or more names joined
# by ", " or " / ", then two spaces or the end of the line. Anything else in the list is prose or a sub-heading.
ENTRY = re.compile(rf"^//\s+(?:\d+[a-z]?\.\s+)?(?P<names>{NAME}(?:(?:, | / ){NAME})*)(?:  |$)")
DEFINITION = re.compile(rf"\b__kernel\b[^;{{]*?\bvoid\s+(?P<name>{NAME})\s*\(")


def strip_comments(source: str) -> str:
    source = re.sub(r"/\*.*?\*/", " ", source, flags=re.DOTALL)
    return re.sub(r"//[^\n]*", "", source)


def listed_kernels(source: str) -> list[str]:
    """The names the header lists, from its "// Kernels" line to its "// Build defines" line or its last comment."""
    names, inside = [], False
    for line in source.splitlines():
        if not line.startswith("//"):
            break  # the header is the file's first comment block
        if line.startswith("// Kernels"):
            inside = True
            continue
        if line.startswith("// Build defines"):
            break
        match = ENTRY.match(line) if inside else None
        if match:
            names += re.split(r", | / ", match["names"])
    return names


def defined_kernels(source: str) -> list[str]:
    """The ``__kernel`` functions in file order (both branches of an #if count: compute_intro.cl defines one name
    per sample)."""
    return [m["name"] for m in DEFINITION.finditer(strip_comments(source))]


@pytest.mark.parametrize("path", KERNEL_FILES, ids=lambda p: p.name)
def test_header_lists_the_kernels_in_file_order(path: Path):
    source = path.read_text()
    listed, defined = listed_kernels(source), defined_kernels(source)
    assert defined, f"{path.name}: no __kernel function found"
    assert listed, f"{path.name}: no kernel list in the header (a '// Kernels' line, then one entry per kernel)"
    assert listed == defined, (
        f"{path.name}: the header lists {listed}\nbut the file defines {defined}"
        f"\n(missing from the header: {sorted(set(defined) - set(listed))}; "
        f"not defined: {sorted(set(listed) - set(defined))})"
    )


@pytest.mark.parametrize("path", KERNEL_FILES, ids=lambda p: p.name)
def test_no_macro_hides_kernel(path: Path):
    code = strip_comments(path.read_text())
    hidden = [line.strip() for line in code.splitlines() if line.lstrip().startswith("#") and "__kernel" in line]
    assert not hidden, f"{path.name}: a macro hides __kernel (spell it out at each kernel): {hidden}"
    # every __kernel of the code is one DEFINITION: none written in a way the pattern above (or a grep) misses
    assert len(re.findall(r"\b__kernel\b", code)) == len(defined_kernels(path.read_text())), path.name


@pytest.mark.parametrize("path", KERNEL_FILES, ids=lambda p: p.name)
def test_variants_use_one_suffix_style(path: Path):
    """A variant of a book kernel is ``<BookName>_<variant>`` (``ForceCS_grid``), never ``ForceGridCS``."""
    for name in defined_kernels(path.read_text()):
        assert not re.fullmatch(r"\w+(Grid|Naive|Atomic)CS", name), f"{path.name}: {name}: write <BookName>_<variant>"


def test_header_parser_on_a_sample():
    sample = """// x.cl: a sample.
// Kernels, in host call order:
//   reset (a sub-heading: one space after the first word)
//   1. First        a -> b: the first kernel
//                   continued here (prose: no two spaces after its first word)
//      First_grid   the same through the grid
//   2b. ScanBlocks, AddBlockOffsets  two kernels on one line
//   then the host swaps a and b.
// Build defines: NotAKernel  none.
__kernel void First(int a) {}
"""
    assert listed_kernels(sample) == ["First", "First_grid", "ScanBlocks", "AddBlockOffsets"]
    assert defined_kernels(sample + "// __kernel void Commented(int a) {}\n") == ["First"]
