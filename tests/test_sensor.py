"""One lens for portrait and landscape photos (``doodle.scenes.sensor``): the quarter turn of a camera, of its
image and of its model, and structure-from-motion on a mixed capture posing one camera."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image, ImageOps

from doodle.scenes.sensor import (one_lens, portrait_from_sensor, portrait_params, portrait_pose, sensor_copies,
                                  write_upright_model)

pycolmap = pytest.importorskip("pycolmap")


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _sensor_camera(k: float = -0.06):
    # an off-centre principal point, so that a wrong turn of it shows
    return pycolmap.Camera(model="SIMPLE_RADIAL", width=400, height=300, params=[550.0, 207.0, 146.0, k])


def test_a_turned_camera_sees_the_turned_image():
    """Points seen by the sensor camera (radial distortion included, through pycolmap's own model) land,
    turned a quarter into the portrait photo, where the portrait camera with the turned pose projects them."""
    rng = np.random.default_rng(0)
    sensor = _sensor_camera()
    R, t = _rotation(rng), np.array([0.1, -0.2, 4.0])
    world = rng.normal(scale=0.8, size=(50, 3))
    xy_s = np.asarray(sensor.img_from_cam((world @ R.T + t)))
    params = portrait_params("SIMPLE_RADIAL", np.asarray(sensor.params), (sensor.width, sensor.height))
    portrait = pycolmap.Camera(model="SIMPLE_RADIAL", width=300, height=400, params=params)
    Rp, tp = portrait_pose(R, t)
    xy_p = np.asarray(portrait.img_from_cam(world @ Rp.T + tp))
    np.testing.assert_allclose(xy_p, portrait_from_sensor(xy_s, portrait.width), atol=1e-9)
    assert np.isclose(np.linalg.det(Rp), 1.0) and np.allclose(Rp @ Rp.T, np.eye(3))
    np.testing.assert_allclose(-Rp.T @ tp, -R.T @ t)  # one camera centre: a turn about the optical axis


def test_two_focal_lengths_cannot_be_turned():
    with pytest.raises(ValueError, match="PINHOLE"):
        portrait_params("PINHOLE", np.array([500.0, 510.0, 200.0, 150.0]), (400, 300))
    assert not one_lens([(400, 300), (300, 400), (640, 480)])  # a second camera's photos


def test_sensor_copies_turn_portrait_photos_the_way_the_points_turn(tmp_path):
    """A mark at (x, y) of a portrait photo lies at ``portrait_from_sensor``'s inverse in its sensor copy;
    landscape photos are the same file."""
    src, out = tmp_path / "src", tmp_path / "sensor"
    src.mkdir()
    portrait = np.zeros((40, 30, 3), np.uint8)
    portrait[5, 22] = 255  # (x, y) = (22, 5)
    Image.fromarray(portrait).save(src / "p.png")
    Image.fromarray(np.full((30, 40, 3), 9, np.uint8)).save(src / "l.png")
    sensor_copies(src, ["p.png", "l.png"], {"p.png"}, out)
    turned = np.asarray(Image.open(out / "p.png"))
    assert turned.shape == (30, 40, 3)
    ys, xs = np.nonzero(turned[..., 0])
    # pixel centres: (22.5, 5.5) in the portrait photo is (x_s, y_s) with (w − y_s, x_s) = (22.5, 5.5)
    back = portrait_from_sensor(np.array([[xs[0] + 0.5, ys[0] + 0.5]]), 30)
    np.testing.assert_allclose(back, [[22.5, 5.5]])
    assert (out / "l.png").read_bytes() == (src / "l.png").read_bytes()



def test_turned_copies_keep_the_photos_focal_length_for_colmap(tmp_path):
    """A phone's EXIF focal length is COLMAP's prior for the camera: a turned copy keeps it (and loses only its
    orientation tag), so that SfM does not start from a guess for the copies alone."""
    src, out = tmp_path / "src", tmp_path / "sensor"
    src.mkdir()
    exif = Image.Exif()
    exif[0x0112] = 6  # stored landscape, shown portrait
    exif.get_ifd(0x8769)[0xA405] = 26  # FocalLengthIn35mmFilm
    Image.fromarray(np.zeros((30, 40, 3), np.uint8)).save(src / "p.jpg", exif=exif.tobytes())
    Image.fromarray(np.zeros((40, 30, 3), np.uint8)).save(src / "q.jpg", exif=exif.tobytes())
    sensor_copies(src, ["p.jpg", "q.jpg"], {"q.jpg"}, out)
    copy = Image.open(out / "q.jpg").getexif()
    assert copy.get(0x0112, 1) == 1 and copy.get_ifd(0x8769).get(0xA405) == 26

def test_the_upright_model_keeps_points_and_turns_only_portrait_views(tmp_path):
    """A two-view model of the sensor images, one of them a portrait photo: written upright, the portrait view
    has a portrait camera and its features project from the 3D points where they are recorded."""
    rng = np.random.default_rng(1)
    rec = pycolmap.Reconstruction()
    sensor = _sensor_camera()
    sensor.camera_id = 1
    rec.add_camera_with_trivial_rig(sensor)
    world = rng.normal(scale=0.5, size=(12, 3))
    poses = [(np.eye(3), np.array([0.0, 0.0, 4.0])), (_rotation(rng), np.array([0.2, 0.1, 4.5]))]
    for image_id, (R, t) in enumerate(poses, start=1):
        xy = np.asarray(sensor.img_from_cam(world @ R.T + t))
        image = pycolmap.Image(name=f"v{image_id}.jpg", points2D=pycolmap.Point2DList([pycolmap.Point2D(p) for p in xy]),
                               camera_id=1, image_id=image_id)
        rec.add_image_with_trivial_frame(image, pycolmap.Rigid3d(pycolmap.Rotation3d(R), t))
    for k, X in enumerate(world):
        track = pycolmap.Track()
        track.add_element(1, k)
        track.add_element(2, k)
        rec.add_point3D(X, track)
    write_upright_model(rec, {"v2.jpg"}, tmp_path)
    up = pycolmap.Reconstruction(str(tmp_path))
    images = {up.image(i).name: up.image(i) for i in up.reg_image_ids()}
    assert len(up.points3D) == 12
    assert (up.camera(images["v1.jpg"].camera_id).width, up.camera(images["v2.jpg"].camera_id).width) == (400, 300)
    for im in images.values():
        cam, pose = up.camera(im.camera_id), im.cam_from_world()
        for p in im.points2D:
            X = up.point3D(p.point3D_id).xyz
            seen = np.asarray(cam.img_from_cam(np.asarray(pose.rotation.matrix()) @ X + np.asarray(pose.translation)))
            np.testing.assert_allclose(seen.ravel(), p.xy, atol=1e-6)


def test_photos_of_both_orientations_are_posed_with_one_lens(tmp_path):
    """A phone capture mixing portrait and landscape photos (some portrait ones stored as landscape pixels with
    an EXIF turn) through one distorting lens: SfM poses one focal length and distortion for all of them, the
    portrait views come back upright, and the camera centres match the true ones. Posing each orientation, or
    each photo, with its own camera put the centres of the 40-photo carpet cow 4.4 % of the radius off."""
    import shutil

    from scipy.spatial import procrustes

    from doodle.samples.capture import write_capture
    from doodle.scenes import load_scene

    cap = write_capture("calf", tmp_path / "capture", n=32, size=320, floor="carpet")
    photos = tmp_path / "photos"
    shutil.copytree(cap / "images", photos)
    scene = load_scene(photos)
    assert len(scene.cameras) >= 20  # of 32 (measured 25)
    rec = pycolmap.Reconstruction(str(photos / ".doodle-sfm" / "model"))
    lenses = {(round(c.params[0], 6), round(c.params[3], 9)) for c in rec.cameras.values()}
    assert len(lenses) == 1, lenses
    assert abs(next(iter(lenses))[0] / 439.5964 - 1) < 0.02  # the capture's true focal length (px)
    for cam, path in zip(scene.cameras, scene.image_paths):
        with Image.open(path) as im:
            assert (cam.width, cam.height) == ImageOps.exif_transpose(im).size, cam.name
    truth = pycolmap.Reconstruction(str(cap / "sparse" / "0"))
    centre = {truth.image(i).name.rsplit(".", 1)[0]: truth.image(i).projection_center() for i in truth.reg_image_ids()}
    est = np.array([c.center for c in scene.cameras])
    _, _, disparity = procrustes(np.array([centre[c.name] for c in scene.cameras]), est)
    assert np.sqrt(disparity) < 0.03
    # an earlier release's cache (a camera per orientation) is reused, with the way to pose them as one lens
    from doodle.scenes.photos import run_sfm

    (photos / ".doodle-sfm" / "one-lens.txt").unlink()
    said = []
    run_sfm(photos, log=said.append)
    assert any("delete" in m and "one lens" in m for m in said), said
