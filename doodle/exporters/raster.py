"""PNG and PDF through cairosvg (same geometry as the SVG), contact sheets through Pillow, and drawings
rasterised to 1-px masks (what the fit judges its outlines and curves by)."""

from __future__ import annotations

import io
import math
from typing import Callable

import cairosvg
import numpy as np
from PIL import Image

from ..cameras import Camera


def svg_to_png(svg: str, background: str | None = "white", scale: float = 1.0,
               size: tuple[int, int] | None = None) -> bytes:
    """Rasterise SVG text at ``scale``, or scaled to ``size = (width, height)``; ``background=None`` keeps
    transparency."""
    fit = {} if size is None else {"output_width": size[0], "output_height": size[1]}
    return cairosvg.svg2png(bytestring=svg.encode("utf-8"), background_color=background, scale=scale, **fit)


def svg_to_pdf(svg: str) -> bytes:
    return cairosvg.svg2pdf(bytestring=svg.encode("utf-8"))


def svg_to_array(svg: str, background: str | None = "white", size: tuple[int, int] | None = None) -> np.ndarray:
    """Rasterise to an ``uint8 (H, W, 4)`` array (at the SVG's own size, or scaled to ``size = (W, H)``)."""
    with Image.open(io.BytesIO(svg_to_png(svg, background, size=size))) as im:
        return np.asarray(im.convert("RGBA"))


def contact_sheet(images: list[Image.Image], columns: int | None = None, cell: int = 256,
                  labels: list[str] | None = None, background: str = "white") -> Image.Image:
    """All images in one grid, each fitted into a ``cell``-pixel square, optional labels underneath."""
    n = len(images)
    columns = columns or max(1, math.ceil(math.sqrt(n)))
    rows = math.ceil(n / columns)
    label_h = 14 if labels else 0
    sheet = Image.new("RGB", (columns * cell, rows * (cell + label_h)), background)
    from PIL import ImageDraw

    draw = ImageDraw.Draw(sheet)
    for k, im in enumerate(images):
        im = im.convert("RGBA")
        im.thumbnail((cell, cell), Image.Resampling.LANCZOS)
        x = (k % columns) * cell + (cell - im.width) // 2
        y = (k // columns) * (cell + label_h) + (cell - im.height) // 2
        sheet.paste(im, (x, y), im)
        if labels:
            draw.text(((k % columns) * cell + 4, (k // columns) * (cell + label_h) + cell), labels[k], fill=(90, 90, 90))
    return sheet


def mask_overlay(image: np.ndarray, mask: np.ndarray) -> Image.Image:
    """A photo ``(H, W, 3)`` (uint8 or float in [0, 1]) with what ``mask`` (``bool (H, W)``) leaves out dimmed
    and its outline in red: how a mask reads against its photo, at a glance."""
    from scipy import ndimage

    rgb = np.asarray(image)[..., :3]
    rgb = (np.clip(rgb, 0, 1) * 255).astype(np.uint8) if rgb.dtype != np.uint8 else rgb.copy()
    rgb[~mask] = (rgb[~mask] * 0.35).astype(np.uint8)
    edge = mask & ~ndimage.binary_erosion(mask, iterations=max(1, max(mask.shape) // 256))
    rgb[edge] = (230, 40, 40)
    return Image.fromarray(rgb)


def masks_sheet(images: list[np.ndarray], masks: list[np.ndarray], names: list[str]) -> Image.Image:
    """A contact sheet of the photos with their masks (:func:`mask_overlay`), labelled with the views' names,
    in cells of at most 256 px (never enlarged)."""
    cell = min(256, max(max(m.shape) for m in masks))
    return contact_sheet([mask_overlay(img, m) for img, m in zip(images, masks)], cell=cell, labels=names)


def ink_paths(img: np.ndarray, ops) -> np.ndarray:
    """Rasterise drawn paths (1 px, in place) into a view's ``bool (H, W)`` image."""
    H, W = img.shape
    for op in ops:
        p = np.floor(op.points()).astype(int)
        ok = (p[:, 0] >= 0) & (p[:, 1] >= 0) & (p[:, 0] < W) & (p[:, 1] < H)
        img[p[ok, 1], p[ok, 0]] = True
    return img


def raster_layer(drawings, cameras: list[Camera], layer: str, owner_of: Callable[[str], int | None]
                 ) -> list[dict[int, np.ndarray]]:
    """Per view, pixel masks of a layer's paths, grouped by ``owner_of(path id)`` (``drawing.curve_of``,
    ``drawing.superquadric_of``); a path it names no owner of is left out."""
    out = []
    for cam, d in zip(cameras, drawings):
        per: dict[int, np.ndarray] = {}
        for op in d.layer(layer):
            owner = owner_of(op.id)
            if owner is not None:
                ink_paths(per.setdefault(owner, np.zeros((cam.height, cam.width), bool)), [op])
        out.append(per)
    return out
