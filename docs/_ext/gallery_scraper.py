"""A sphinx-gallery image scraper for the PNG files an example writes (coordarm draws figures to files).

An example writes its figures under ``logs/`` of the folder it runs in, as the command line does;
after each code block this scraper picks up the PNG files written since the last block and shows
them in the gallery like matplotlib figures.
"""
from __future__ import annotations

import shutil
import time
from pathlib import Path

_STATE = {"since": 0.0}


def reset(gallery_conf: dict, fname: str) -> None:
    """Called by sphinx-gallery before each example: only files written from now on are shown."""
    _STATE["since"] = time.time()


def png_files(block, block_vars: dict, gallery_conf: dict) -> str:
    """Copy the new PNG files of ``logs/`` into the gallery and return their reST.

    Parameters
    ----------
    block, block_vars, gallery_conf
        As sphinx-gallery passes them to a scraper.

    Returns
    -------
    str
        The images' reST (empty when the block wrote none).
    """
    from sphinx_gallery.scrapers import figure_rst

    folder = Path(block_vars["src_file"]).parent / "logs"
    new = sorted((p for p in folder.rglob("*.png") if p.stat().st_mtime >= _STATE["since"]),
                 key=lambda p: p.stat().st_mtime) if folder.is_dir() else []
    _STATE["since"] = time.time()
    images = []
    for png, target in zip(new, block_vars["image_path_iterator"]):
        shutil.copyfile(png, target)
        images.append(target)
    return figure_rst(images, gallery_conf["src_dir"])
