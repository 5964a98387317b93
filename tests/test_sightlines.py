"""The views see through the hull where they show a curve it hides (``doodle.fit.discovery.sightlines``)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from doodle.cameras import Camera
from doodle.cameras.camera import look_at
from doodle.fit.discovery.evidence import Evidence, depth_maps
from doodle.fit.volume.carve import VoxelGrid
from doodle.fit.discovery.sightlines import seen_through
from doodle.fit.volume.hull import clear_seen
from doodle.strokes.bezier import bezier_points
from doodle.strokes.model import Voxels

N = 40
H = 2.0 / N  # voxel


def _box_hull_with_buried_edge(shift_px: float = 0.0, views_with_lines: int | None = None):
    """A box hull ``|x|, |y|, |z| ≤ 0.5`` whose top is a lid over empty space (a concavity no silhouette
    carves), with a real edge 8 voxels under the lid: every view's line map shows it (shifted by
    ``shift_px`` in x, or drawn only in the first ``views_with_lines`` views)."""
    grid = VoxelGrid(np.full(3, -1.0 + 0.5 * H), H, (N, N, N))
    c = grid.centres(np.argwhere(np.ones((N, N, N), bool))).reshape(N, N, N, 3)
    occupied = np.all(np.abs(c) <= 0.5, axis=-1)
    z = 0.5 - 8 * H
    edge = np.array([[[-0.3, 0.1, z], [-0.1, 0.1, z], [0.1, 0.1, z], [0.3, 0.1, z]]])
    cams = []
    for az in np.radians([0, 60, 120, 180, 240, 300]):
        eye = 4.0 * np.array([np.cos(az) * 0.5, np.sin(az) * 0.5, 0.87])
        R, t = look_at(eye, np.zeros(3), np.array([0.0, 0.0, 1.0]))
        cams.append(Camera(300.0, 300.0, 64.0, 64.0, 128, 128, R, t))
    lines = []
    for k, cam in enumerate(cams):
        m = np.zeros((128, 128), bool)
        if views_with_lines is None or k < views_with_lines:
            uv, _ = cam.project(bezier_points(edge[0], np.linspace(0, 1, 400)))
            u = np.floor(uv[:, 0] + shift_px).astype(int)
            v = np.floor(uv[:, 1]).astype(int)
            m[v, u] = True
        lines.append(m)
    depth = depth_maps(grid, occupied, cams)
    ev = Evidence(grid, np.zeros(occupied.shape, np.float32), occupied, np.zeros(occupied.shape, np.int16), cams,
                  lines, depth, 2 * H)
    return ev, edge


def test_a_curve_the_views_show_under_the_hull_clears_its_sight_lines_and_nothing_deeper():
    ev, edge = _box_hull_with_buried_edge()
    free = seen_through(edge, ev)
    assert free.any()
    pts = ev.grid.centres(np.argwhere(free))
    # only between the edge and the lid, over the edge (the lid is the box's top face), never below it
    assert pts[:, 2].min() > edge[0, 0, 2]
    assert np.abs(pts[:, 0]).max() < 0.5 and pts[:, 1].max() < 0.5
    # the depth maps without the cleared voxels see the edge in the views
    depth = depth_maps(ev.grid, ev.occupied & ~free, ev.cameras)
    cam = ev.cameras[0]
    mid = np.array([[0.0, 0.1, edge[0, 0, 2]]])
    uv, z = cam.project(mid)
    u, v = np.floor(uv[0]).astype(int)
    assert ev.depth[0][v, u] < z[0] - 4 * H
    assert depth[0][v, u] >= z[0] - 2 * H
    # what is cleared is not hidden in the drawings either: the occluder over the edge opens
    occ = Voxels(ev.grid.origin, ev.grid.voxel, np.eye(3), ev.occupied.copy())
    cleared = clear_seen(occ, ev.grid, free)
    assert cleared.occupied.sum() == occ.occupied.sum() - free.sum()
    # nothing deeper than asked
    shallow = seen_through(edge, ev, max_depth=3)
    assert shallow.any() and not shallow[ndimage.distance_transform_edt(ev.occupied) > 3].any()


@pytest.mark.parametrize("case", ["lines beside it", "one view only", "on the outline", "beside a visible curve"])
def test_a_curve_not_shown_by_two_views_clears_nothing(case):
    ev, edge = _box_hull_with_buried_edge(**({"shift_px": 4.0} if case == "lines beside it" else
                                             {"views_with_lines": 1} if case == "one view only" else {}))
    if case == "on the outline":  # its lines are the outline's: the outline explains them
        assert not seen_through(edge, ev, outlines=ev.lines).any()
    elif case == "beside a visible curve":
        # a curve on the lid, over the buried edge as the first two views see it: it explains their lines
        lids = []
        for cam in ev.cameras[:2]:
            uv, _ = cam.project(edge[0])
            lids.append(cam.rays_at(uv[:, 0], uv[:, 1]))
        candidates = [edge[0]]
        for (o, d), cam in zip(lids, ev.cameras[:2]):
            s = (0.5 + 0.25 * H - o[:, 2]) / d[:, 2]  # where those rays meet the lid, a quarter voxel above it
            candidates.append(o + s[:, None] * d)
        for k in range(2, len(ev.lines)):
            ev.lines[k][:] = False  # the other views show nothing: the first two alone would have to see it
        free_alone = seen_through(edge, ev)
        assert free_alone.any()
        assert not seen_through(np.stack(candidates), ev).any()
    else:
        assert not seen_through(edge, ev).any()


def test_a_curve_the_hull_does_not_hide_clears_nothing():
    ev, edge = _box_hull_with_buried_edge()
    lifted = edge + np.array([0.0, 0.0, 8 * H])  # on the lid: in sight already
    lifted_lines = []
    for cam in ev.cameras:
        m = np.zeros((128, 128), bool)
        uv, _ = cam.project(bezier_points(lifted[0], np.linspace(0, 1, 400)))
        m[np.floor(uv[:, 1]).astype(int), np.floor(uv[:, 0]).astype(int)] = True
        lifted_lines.append(m)
    ev.lines[:] = lifted_lines
    assert not seen_through(lifted, ev).any()
