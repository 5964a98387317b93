"""Hollows (eye sockets, a nose, a mouth): dark regions the views agree on, carved and drawn as rings."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from doodle.fit.discovery.evidence import depth_maps
from doodle.fit.discovery.hollows import DEEP, clear_of, dark_regions, find_hollows
from doodle.fit.discovery.salience import choose_features, feature_cubics, score_features
from doodle.fit.volume.carve import VoxelGrid
from doodle.samples import sample_cameras
from doodle.strokes.bezier import bezier_points
from doodle.strokes.fitcurve import fit_cubics_many
from doodle.strokes.model import SuperquadricSet

RADIUS = 0.6
SKULL = Path(__file__).resolve().parents[2] / "shared" / "data" / "dtu" / "scan65"


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _sphere_views(spots: list[tuple[np.ndarray, float]], n: int = 24, size: int = 128):
    """Views of a grey sphere with dark spots ``(direction, angular radius in degrees)`` (a spot of several
    discs: the same direction-and-radius pairs, in a list): cameras, images, masks."""
    cams = sample_cameras("train", n, size)
    spots = [disc for spot in spots for disc in (spot if isinstance(spot, list) else [spot])]
    images, masks = [], []
    for cam in cams:
        o, d = cam.rays()
        b = (o * d).sum(-1)
        disc = b * b - ((o * o).sum(-1) - RADIUS**2)
        hit = disc > 0
        t = -b - np.sqrt(np.maximum(disc, 0))
        p = (o + t[..., None] * d) / RADIUS
        shade = 150 + 60 * np.clip(p[..., 2], 0, 1)  # lit from above: a gentle ramp, no hollow
        for direction, angle in spots:
            shade = np.where(p @ direction > math.cos(math.radians(angle)), 25, shade)
        images.append(np.where(hit, shade, 255).astype(np.uint8)[..., None].repeat(3, -1))
        masks.append(hit)
    return cams, images, masks


def _sphere_hull(voxels: int = 64) -> tuple[VoxelGrid, np.ndarray]:
    h = 1.6 / (voxels - 1)
    grid = VoxelGrid(np.full(3, -0.8), h, (voxels,) * 3)
    ijk = np.indices(grid.shape).reshape(3, -1).T
    return grid, (np.linalg.norm(grid.centres(ijk), axis=1) <= RADIUS).reshape(grid.shape)


def test_dark_regions_are_darker_than_the_object_round_them_and_inside_its_outline():
    H = W = 96
    y, x = np.mgrid[:H, :W]
    mask = (x - 48) ** 2 + (y - 48) ** 2 <= 40**2
    image = np.full((H, W), 200.0) - 0.8 * (x - 48)  # shading: a ramp across the object
    image[(x - 40) ** 2 + (y - 45) ** 2 <= 5**2] = 30  # a hollow
    image[(x - 48) ** 2 + (y - 86) ** 2 <= 6**2] = 30  # dark at the outline: a shaded side, not a hollow
    dark, drop = dark_regions(np.repeat(image[..., None], 3, -1).astype(np.uint8), mask)
    assert dark[45, 40] and drop[45, 40] > DEEP
    assert not dark[84, 48]
    assert dark.sum() < 100  # only the hollow: the ramp is nowhere dark against its surroundings
    assert not dark[~mask].any()


@pytest.fixture(scope="module")
def spotted_sphere():
    eye = _unit([1.0, 0.3, 0.5])
    cams, images, masks = _sphere_views([(eye, 12.0)])
    grid, occupied = _sphere_hull()
    depth = depth_maps(grid, occupied, cams)
    return eye, cams, images, masks, grid, occupied, depth


def test_a_region_every_view_sees_dark_is_found_as_one_ring_round_it(spotted_sphere):
    eye, cams, images, masks, grid, occupied, depth = spotted_sphere
    found = find_hollows(grid, occupied, cams, images, masks, depth, 0.01)
    assert len(found) == 1, [h.points.mean(0) for h in found]
    hollow = found[0]
    centre = hollow.points.mean(0)
    assert math.degrees(math.acos(np.clip(_unit(centre) @ eye, -1, 1))) < 8  # where the spot is
    assert hollow.facing @ eye > 0.9  # facing out of it
    spot = RADIUS * math.sin(math.radians(12.0))
    extent = np.linalg.norm(hollow.points - centre, axis=1).max()
    assert 0.5 * spot < extent < 1.6 * spot
    assert abs(np.linalg.norm(centre) - RADIUS) < 0.1  # on the surface, not at the centre of the lens
    assert np.allclose(hollow.cubics[0, 0], hollow.cubics[-1, 3])  # closed
    assert hollow.share >= 0.5 and hollow.darkness >= DEEP


def test_a_hollows_ring_follows_its_opening_as_the_view_facing_it_sees_it():
    """A dark peanut (two overlapping discs, pinched between them): its ring is traced at the pixels of the
    view facing it, so it has the pinch, which the vote's coarse grid rounds away, and lies on the surface."""
    eye = _unit([1.0, 0.3, 0.5])
    side = _unit(np.cross(eye, [0.0, 0.0, 1.0]))
    lobes = [(_unit(np.cos(np.radians(a)) * eye + np.sin(np.radians(a)) * side), 9.0) for a in (-8.0, 8.0)]
    cams, images, masks = _sphere_views([lobes], size=256)
    grid, occupied = _sphere_hull()
    found = find_hollows(grid, occupied, cams, images, masks, depth_maps(grid, occupied, cams), 0.004)
    assert len(found) == 1
    ring = found[0]
    samples = bezier_points(ring.cubics, np.linspace(0, 1, 16)).reshape(-1, 3)
    assert np.abs(np.linalg.norm(samples, axis=1) - RADIUS).max() < 0.03  # on the sphere's surface
    facing = max(range(len(cams)), key=lambda k: _unit(cams[k].center) @ eye)
    dark = images[facing][..., 0] < 100
    edge = dark & ~ndimage.binary_erosion(dark)
    to_edge = ndimage.distance_transform_edt(~edge)
    uv = np.asarray(cams[facing].project(samples)[0])
    off = to_edge[np.clip(uv[:, 1].astype(int), 0, 255), np.clip(uv[:, 0].astype(int), 0, 255)]
    assert off.mean() < 1.0 and off.max() < 2.5, (off.mean(), off.max())


def test_a_plain_object_has_no_hollows(spotted_sphere):
    _, cams, _, masks, grid, occupied, depth = spotted_sphere
    _, images, _ = _sphere_views([])
    assert find_hollows(grid, occupied, cams, images, masks, depth, 0.01) == []


def test_a_ring_under_a_bulging_superquadric_is_moved_out_until_the_views_see_it():
    a = np.linspace(0, 2 * np.pi, 33)
    ring = np.stack([0.2 * np.cos(a), 0.2 * np.sin(a), np.full(33, 0.9)], -1)
    cubics = fit_cubics_many([ring], 1e-3, [True])[0]
    sphere = SuperquadricSet(np.ones((1, 3)), np.ones((1, 2)), np.array([[1.0, 0, 0, 0]]), np.zeros((1, 3)))
    cameras = sample_cameras("train", 24, 64)  # the upper hemisphere: those within 60° of the pole face the ring
    up = np.array([0.0, 0.0, 1.0])
    moved = clear_of(cubics, up, sphere, cameras, reach=0.5, step=0.02, margin=0.01)
    lift = bezier_points(moved, np.linspace(0, 1, 8))[..., 2].min() - 0.9
    assert 0.05 < lift < 0.2  # out to the sphere's cap (z ≤ 1), not beyond
    assert clear_of(cubics, up, sphere, cameras, reach=0.04, step=0.02, margin=0.01) is None  # no view would see it
    assert clear_of(cubics, -up, sphere, cameras, reach=0.5, step=0.02, margin=0.01) is None  # no view faces it
    assert clear_of(cubics, up, SuperquadricSet(), cameras, 0.5, 0.02, 0.01) is cubics


def test_a_ring_inside_the_occluder_is_moved_out_of_it_too():
    from doodle.strokes.model import Voxels

    a = np.linspace(0, 2 * np.pi, 33)
    ring = np.stack([0.2 * np.cos(a), 0.2 * np.sin(a), np.full(33, 0.7)], -1)
    cubics = fit_cubics_many([ring], 1e-3, [True])[0]
    block = Voxels(np.full(3, -0.95), 0.1, np.eye(3), np.ones((20, 20, 20), bool))  # the cube |x| ≤ 1
    cameras = sample_cameras("train", 24, 64)
    up = np.array([0.0, 0.0, 1.0])
    moved = clear_of(cubics, up, SuperquadricSet(), cameras, reach=0.8, step=0.02, margin=0.01, volume=block)
    # out to its top face (z = 1), less the slack the drawing allows a curve under the occluder's surface
    assert 0.15 < bezier_points(moved, np.linspace(0, 1, 8))[..., 2].min() - 0.7 < 0.35


def test_hollows_are_features_drawn_by_their_own_rings(spotted_sphere):
    eye, cams, images, masks, grid, occupied, depth = spotted_sphere
    hollows = find_hollows(grid, occupied, cams, images, masks, depth, 0.01)
    scored = score_features(np.zeros((0, 4, 3)), np.zeros(0, int), np.zeros((0, 4, 3)), np.zeros(grid.shape), grid,
                            occupied, hollows=hollows)
    assert len(scored) == 1 and scored[0].hollow is hollows[0] and scored[0].closed == 1.0
    taken = choose_features(scored, 3, 2 * grid.voxel, open_features=False)
    assert taken and feature_cubics(taken[0], np.zeros((0, 4, 3)), 0.01) is hollows[0].cubics


@pytest.mark.skipif(not SKULL.is_dir(), reason="../shared/data/dtu/scan65 is not here")
def test_the_skulls_eye_sockets_nose_and_mouth_are_found():
    """DTU's skull (real photos, true masks): rings round its eye sockets, its nose and the gap of a missing
    tooth, where the frontal photo shows them (points read off 000024.png, 800 × 600, each inside a ring as that
    view draws it), and not many more."""
    from skimage.measure import points_in_poly

    from doodle.fit.volume.carve import carve_hull
    from doodle.scenes import load_scene_at_size

    scene = load_scene_at_size(SKULL, size=256)
    grid, occupied = carve_hull(scene, 96)
    depth = depth_maps(grid, occupied, scene.cameras)
    found = find_hollows(grid, occupied, scene.cameras, scene.images, scene.masks, depth, 1.5 * grid.voxel)
    cam = scene.cameras[24]
    rings = [np.asarray(cam.project(bezier_points(chain, np.linspace(0, 1, 8)).reshape(-1, 3))[0]) * 800 / cam.width
             for h in found for chain in np.split(h.cubics, np.flatnonzero(
                 np.linalg.norm(h.cubics[1:, 0] - h.cubics[:-1, 3], axis=1) > 1e-9) + 1)]
    annotated = {"right eye socket": (280, 285), "left eye socket": (430, 295), "nose": (330, 355),
                 "missing tooth": (300, 487)}
    for name, at in annotated.items():
        assert any(points_in_poly([at], ring)[0] for ring in rings), (name, [r.mean(0).round() for r in rings])
    assert len(found) <= len(annotated) + 3


def test_the_wide_local_mean_is_the_gaussians():
    """The dark regions' local mean (a Gaussian tens of pixels wide) computed on blocks equals scipy's filter."""
    from doodle.fit.discovery.hollows import wide_gaussian

    rng = np.random.default_rng(0)
    image = ndimage.gaussian_filter(rng.random((301, 403)), 4.0).astype(np.float32)
    for sigma in (5.0, 24.0, 40.0):
        fast, exact = wide_gaussian(image, sigma), ndimage.gaussian_filter(image, sigma)
        spread = float(np.ptp(exact[60:-60, 60:-60]))
        assert fast.shape == image.shape
        assert np.abs(fast - exact)[60:-60, 60:-60].max() < 0.05 * spread
        assert np.abs(fast - exact).max() < 0.3 * spread  # the image's edges: blocks reflected, not pixels
