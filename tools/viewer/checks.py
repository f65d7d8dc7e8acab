"""What the viewer check fails on: problems the app lists, and panels that show nothing or the wrong thing.

Each check reads either the page (the DOM through :class:`browser.Browser`) or the screenshot (a PNG,
read with Pillow), and returns a list of one-line problems (empty: passed).
"""
from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
from PIL import Image

from coordarm.simulation.scene import margin_colours

#: Colours of coordarm's scene (0-255), from ``coordarm.simulation.scene``: the links at a margin of
#: 0.5 or more, the curve, obstacles (walls, outlines) and the rail.
LINK_BLUE, CURVE_ORANGE, WALL_GREY, RAIL_GREY = (38, 115, 230), (230, 128, 26), (51, 51, 51), (115, 115, 115)
#: The links' hues [deg] and least saturation: blue (margin 0.5 and above; lit cylinders are shaded, so
#: the hue is what stays) down to about margin 0.4; the grid's light blue is less saturated.
LINK_HUES, LINK_SATURATION = (200.0, 235.0), 0.35
#: The link colours of margins 0.28 to 0.5 (coordarm's scale), 0-255.
LINK_SCALE = tuple(tuple(int(round(255 * c)) for c in rgb)
                   for rgb in margin_colours(np.linspace(0.28, 0.5, 23)[None])[0, 1:].tolist())

#: JavaScript: every canvas on the page with its rectangle [CSS px] and the title of its panel.
CANVASES_JS = """
[...document.querySelectorAll('canvas')].map(c => {
  const r = c.getBoundingClientRect();
  const panel = c.closest('.mosaic-window');
  return {x: r.x, y: r.y, w: r.width, h: r.height, title: panel ? panel.innerText.split('\\n')[0] : ''};
}).filter(c => c.w > 0 && c.h > 0)
"""

#: JavaScript: the text of the data source sidebar's tabs (``Problems`` carries a count when the
#: player lists problems) and of the problem list when it is shown.
PROBLEMS_JS = """
(() => {
  const tabs = [...document.querySelectorAll('[role=tab]')].map(t => t.innerText.replace(/\\s+/g, ' ').trim());
  const body = document.body.innerText;
  return {tabs, body};
})()
"""

#: Text the app shows when it cannot read or reach the data source.
FAILURE_TEXTS = ("Connection failed", "Failed to fetch", "Unsupported extension", "Missing url argument",
                 "Error loading", "Insufficient data", "Check that the WebSocket server")


@dataclass(frozen=True)
class Rect:
    """A rectangle of the page [CSS px = screenshot px]."""

    x: int
    y: int
    w: int
    h: int
    title: str = ""


def canvases(page) -> list[Rect]:
    """The page's visible canvases, with the titles of their panels."""
    return [Rect(round(c["x"]), round(c["y"]), round(c["w"]), round(c["h"]), c["title"])
            for c in page.evaluate(CANVASES_JS)]


def listed_problems(page) -> list[str]:
    """Problems the app lists for the data source (the *Problems* tab's count) or failures it shows."""
    state = page.evaluate(PROBLEMS_JS)
    found = [f"the app lists problems: tab '{t}'" for t in state["tabs"] if t.startswith("Problems") and t != "Problems"]
    found += [f"the page shows '{text}'" for text in FAILURE_TEXTS if text in state["body"]]
    return found


def pixels(png: bytes, rect: Rect) -> np.ndarray:
    """The RGB pixels of ``rect`` in a screenshot, shape (h, w, 3), uint8."""
    image = Image.open(io.BytesIO(png)).convert("RGB")
    return np.asarray(image.crop((rect.x, rect.y, rect.x + rect.w, rect.y + rect.h)))


def near(rgb: np.ndarray, colour: tuple[int, int, int], tolerance: int = 28) -> np.ndarray:
    """Mask of the pixels within ``tolerance`` (per channel, 0-255) of ``colour``, shape (h, w)."""
    return np.all(np.abs(rgb.astype(int) - np.array(colour)) <= tolerance, axis=-1)


def link_mask(rgb: np.ndarray) -> np.ndarray:
    """Mask of the pixels drawn in the links' colours (hue within :data:`LINK_HUES`, saturation above
    :data:`LINK_SATURATION`, or a colour of :data:`LINK_SCALE`), shape (h, w)."""
    x = rgb.astype(float) / 255.0
    hi, lo = x.max(axis=-1), x.min(axis=-1)
    chroma = hi - lo
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    safe = np.where(chroma > 0, chroma, 1.0)
    hue = np.where(hi == b, 240.0 + 60.0 * (r - g) / safe,
                   np.where(hi == g, 120.0 + 60.0 * (b - r) / safe, (60.0 * (g - b) / safe) % 360.0))
    saturation = np.where(hi > 0, chroma / np.where(hi > 0, hi, 1.0), 0.0)
    blue = (chroma > 0) & (hue >= LINK_HUES[0]) & (hue <= LINK_HUES[1]) & (saturation > LINK_SATURATION)
    scale = np.zeros(blue.shape, bool)
    for colour in LINK_SCALE:      # the unlit planar links at every margin from 0.28 up (greyish mid-scale)
        scale |= near(rgb, colour, 8)
    return blue | scale


def scene_problems(png: bytes, rect: Rect, *, obstacles: bool, rail: bool, margin: int = 4,
                   least: int = 150, least_links: int = 500) -> list[str]:
    """What is missing or cut off in the 3D panel: the links (blue), the curve (orange), the obstacles
    (dark grey), the rail (grey); the links must lie inside the panel, ``margin`` px clear of its edges.

    Parameters
    ----------
    png : bytes
        The screenshot.
    rect : Rect
        The 3D panel's canvas.
    obstacles, rail : bool
        Whether the scene has obstacles, a rail.
    margin : int
        Clearance of the links from the panel's edges [px].
    least, least_links : int
        Fewest pixels of a drawn item's colour that count as drawn (the links: more, as the frame
        axes' z arrows are blue too).
    """
    rgb = pixels(png, rect)
    found = []
    links = link_mask(rgb)
    masks = [("links (blue)", links), ("curve (orange)", near(rgb, CURVE_ORANGE))]
    masks += [("obstacles (dark grey)", near(rgb, WALL_GREY))] if obstacles else []
    masks += [("rail (grey)", near(rgb, RAIL_GREY))] if rail else []
    for name, mask in masks:
        count = int(mask.sum())
        if count < (least_links if mask is links else least):
            found.append(f"3D panel: {name} not drawn ({count} px of its colour)")
    rows, cols = np.nonzero(links)
    if len(rows) >= least:
        h, w = rgb.shape[:2]
        if rows.min() < margin or cols.min() < margin or rows.max() >= h - margin or cols.max() >= w - margin:
            found.append(f"3D panel: the links reach the panel's edge (rows {rows.min()}-{rows.max()} of {h}, "
                         f"columns {cols.min()}-{cols.max()} of {w})")
    return found


def plot_problems(png: bytes, rect: Rect, least: int = 60, height: int = 80, whole: bool = False) -> list[str]:
    """A plot whose drawing area is under ``height`` px high (its legend or neighbours took the rest), that
    draws no curve (fewer than ``least`` saturated pixels: series colours; the axes, grid and labels are
    grey), or, if ``whole``, whose curves stop short of the right end (the last 8 % of the width: the
    data of the whole log is not drawn yet)."""
    if rect.h < height:
        return [f"plot '{rect.title}': drawing area {rect.h} px high (under {height})"]
    rgb = pixels(png, rect).astype(int)
    saturated = (rgb.max(axis=-1) - rgb.min(axis=-1)) > 80
    count = int(saturated.sum())
    if count < least:
        return [f"plot '{rect.title}': no curve drawn ({count} coloured px)"]
    if whole and not saturated[:, -max(3, rect.w * 8 // 100):].any():
        return [f"plot '{rect.title}': the curves stop short of the log's end"]
    return []
