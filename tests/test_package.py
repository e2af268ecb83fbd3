"""Packaging: setup.cfg installs every package folder of the tree, with the kernels and shaders as package data."""

from __future__ import annotations

import configparser
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def declared() -> tuple[set[str], dict[str, str]]:
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    packages = {p.strip() for p in cfg["options"]["packages"].split() if p.strip()}
    mapping = dict(
        (name.strip(), folder.strip())
        for line in cfg["options"]["package_dir"].strip().splitlines()
        for name, folder in [line.split("=")]
    )
    return packages, mapping


def test_every_package_folder_is_installed():
    packages, mapping = declared()
    found = set()
    for top, name in (("ugpcl", "ugpcl"), *((folder, name) for name, folder in mapping.items())):
        for init in (ROOT / top).rglob("__init__.py"):
            relative = init.parent.relative_to(ROOT / top).parts
            found.add(".".join((name, *relative)))
    assert found == packages, f"setup.cfg [options] packages lacks {found - packages} / lists {packages - found}"


def test_kernels_and_shaders_are_package_data():
    import ugpcl.clkernels
    import ugpcl.viewer

    from ugpcl.runtime import KERNEL_DIR

    assert KERNEL_DIR == Path(ugpcl.clkernels.__file__).parent and (KERNEL_DIR / "boids.cl").is_file()
    assert (Path(ugpcl.viewer.__file__).parent / "shaders" / "boids.vert").is_file()
