"""What the objectives compare against, per training view at the working resolution.

Masks come from the scene; line maps are the mask boundary plus strong image edges (Canny, scikit-image)
inside the object; their Euclidean distance transforms (scipy) let the objectives measure how far a
projected stroke is from the nearest line with one bilinear lookup, without rasterising anything.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from scipy import ndimage
from skimage import feature

from ...arrays import silhouette_boundary
from ...cameras import Camera
from ...scenes import Scene


def line_map(image: np.ndarray, mask: np.ndarray | None, sigma: float = 2.0) -> np.ndarray:
    """Boolean lines: mask boundary (not the frame's edge where the object runs out of the photo) ∪ Canny edges
    of the image inside the (slightly grown) mask.

    Thresholds are quantiles of the gradient magnitude so they adapt to the image's contrast.
    """
    gray = image.astype(np.float32).mean(axis=2) / 255.0
    edges = feature.canny(gray, sigma=sigma, low_threshold=0.75, high_threshold=0.9, use_quantiles=True)
    if mask is None:
        return edges
    boundary = silhouette_boundary(mask)
    inside = ndimage.binary_erosion(mask, iterations=2)
    return boundary | (edges & inside)


def straightness(scene: Scene, views: int = 8) -> float:
    """Share of line-map pixels lying on long straight segments (probabilistic Hough, segments ≥ 12 % of the
    image), averaged over ``views`` views: ≈ 0.7 for a boxy chair, 0.3 for Lego, < 0.1 for a snowman."""
    from skimage.draw import line as draw_line
    from skimage.transform import probabilistic_hough_line

    fractions = []
    for k in range(0, len(scene), max(1, len(scene) // views)):
        lm = line_map(scene.images[k], scene.masks[k] if scene.masks is not None else None)
        if not lm.any():
            continue
        segs = probabilistic_hough_line(lm, threshold=10, line_length=int(0.12 * max(lm.shape)), line_gap=2, rng=0)
        on = np.zeros_like(lm)
        for (x0, y0), (x1, y1) in segs:
            rr, cc = draw_line(y0, x0, y1, x1)
            on[rr, cc] = True
        fractions.append((ndimage.binary_dilation(on) & lm).sum() / lm.sum())
    return float(np.mean(fractions)) if fractions else 0.0


@dataclass
class ViewTargets:
    """Tensors for all training views (``V`` views). Views of different sizes or orientations are padded at
    the right and bottom to the largest ``H × W``; cameras keep their own size, the padding holds no mask and
    no line (``valid`` marks real pixels)."""

    R: torch.Tensor  # (V, 3, 3)
    t: torch.Tensor  # (V, 3)
    K: torch.Tensor  # (V, 4) fx, fy, cx, cy
    masks: torch.Tensor | None  # (V, H, W) float
    valid: torch.Tensor  # (V, H, W) float: 1 inside each view's own frame, 0 in the padding
    lines: list[np.ndarray]  # V boolean (H, W) line maps (before removing what silhouettes draw)
    line_dist: torch.Tensor  # (V, H, W) distance in px to the nearest line pixel
    line_pixels: list[torch.Tensor]  # V × (L_v, 2) pixel centres (u, v) of line pixels
    boundary_pixels: list[torch.Tensor] | None  # V × (B_v, 2) mask-boundary pixel centres
    cameras: list[Camera]
    width: int
    height: int

    @property
    def views(self) -> int:
        return int(self.R.shape[0])


def _pad(a: np.ndarray, H: int, W: int) -> np.ndarray:
    """``a (h, w)`` padded with zeros (False) at the bottom and right to ``(H, W)``; pixel coordinates and so
    each camera's intrinsics stay valid."""
    if a.shape == (H, W):
        return a
    return np.pad(a, ((0, H - a.shape[0]), (0, W - a.shape[1])))


def build_targets(scene: Scene, device: str = "cpu", exclude: list[np.ndarray] | None = None) -> ViewTargets:
    """Targets of a (working-size) scene; ``exclude`` masks out line pixels already drawn (silhouettes)."""
    cams = scene.cameras
    H = max(img.shape[0] for img in scene.images)
    W = max(img.shape[1] for img in scene.images)
    lines, dists, pix, bpix, valid, masks = [], [], [], [], [], []
    for k, img in enumerate(scene.images):
        m = scene.masks[k] if scene.masks is not None else None
        lm = line_map(img, m)
        lines.append(lm)
        use = lm & ~exclude[k] if exclude is not None else lm
        if not use.any():
            use = lm
        dists.append(ndimage.distance_transform_edt(~_pad(use, H, W)).astype(np.float32))
        valid.append(_pad(np.ones(img.shape[:2], bool), H, W))
        if m is not None:
            masks.append(_pad(m, H, W))
        vv, uu = np.nonzero(use)
        pix.append(torch.tensor(np.stack([uu + 0.5, vv + 0.5], 1), dtype=torch.float32, device=device))
        if m is not None:
            bv, bu = np.nonzero(silhouette_boundary(m))
            bpix.append(torch.tensor(np.stack([bu + 0.5, bv + 0.5], 1), dtype=torch.float32, device=device))
    f32 = dict(dtype=torch.float32, device=device)
    return ViewTargets(
        R=torch.tensor(np.stack([c.R for c in cams]), **f32),
        t=torch.tensor(np.stack([c.t for c in cams]), **f32),
        K=torch.tensor(np.stack([c.K for c in cams]), **f32),
        masks=torch.tensor(np.stack(masks), **f32) if scene.masks is not None else None,
        valid=torch.tensor(np.stack(valid), **f32),
        lines=lines,
        line_dist=torch.tensor(np.stack(dists), **f32),
        line_pixels=pix,
        boundary_pixels=bpix if scene.masks is not None else None,
        cameras=cams, width=W, height=H,
    )


def project(points: torch.Tensor, R: torch.Tensor, t: torch.Tensor, K: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Batched perspective projection: points ``(P, 3)`` into ``V`` views → ``uv (V, P, 2)``, ``depth (V, P)``."""
    pc = torch.einsum("vij,pj->vpi", R, points) + t[:, None, :]
    z = pc[..., 2]
    uv = pc[..., :2] / z.clamp_min(1e-6)[..., None] * K[:, None, :2] + K[:, None, 2:]
    return uv, z


def lookup(field: torch.Tensor, uv: torch.Tensor) -> torch.Tensor:
    """Bilinear samples of per-view images ``(V, H, W)`` at pixel positions ``uv (V, P, 2)`` → ``(V, P)``.

    Outside the image the border value is used (a distance field keeps growing only inside the frame)."""
    V, H, W = field.shape
    grid = torch.stack([uv[..., 0] / W * 2 - 1, uv[..., 1] / H * 2 - 1], -1)[:, None]  # (V, 1, P, 2)
    return torch.nn.functional.grid_sample(field[:, None], grid, mode="bilinear", padding_mode="border",
                                           align_corners=False)[:, 0, 0]
