import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from doodle.errors import StrokeFileError
from doodle.strokes import dumps, loads, read_strokes, stroke_set_to_dict, write_strokes
from doodle.strokes.binary import decode, encode
from doodle.strokes.superquadric import quaternion_to_matrix

from helpers import random_strokes


#: Where a version 5 file's flags byte lies: after the head (8 bytes), the frame (68) and the quantisation (42).
_FLAGS_AT = 8 + 68 + 42


def _assert_close(a, b, tol, normal_deg=0.01):
    assert np.abs(a.curves.control_points - b.curves.control_points).max(initial=0) <= tol
    assert (a.curves.normals is None) == (b.curves.normals is None)
    if a.curves.normals is not None:
        na, nb = a.curves.normals, b.curves.normals
        assert ((np.linalg.norm(na, axis=-1) < 1e-9) == (np.linalg.norm(nb, axis=-1) < 1e-9)).all()
        cos = np.clip((na * nb).sum(-1), -1, 1)[np.linalg.norm(na, axis=-1) > 1e-9]
        assert np.degrees(np.arccos(cos)).max(initial=0) <= normal_deg
    assert (a.superquadrics.drawn == b.superquadrics.drawn).all()
    sa, sb = a.superquadrics, b.superquadrics
    assert np.array_equal(sa.drawn_cells, sb.drawn_cells)
    assert np.abs(sa.translation - sb.translation).max(initial=0) <= tol
    assert np.abs(sa.scale - sb.scale).max(initial=0) <= tol
    assert np.abs(sa.shape - sb.shape).max(initial=0) <= 1e-3
    assert np.abs(quaternion_to_matrix(sa.rotation) - quaternion_to_matrix(sb.rotation)).max(initial=0) <= 1e-3


class TestJson:
    def test_round_trip_exact_enough(self, tmp_path):
        s = random_strokes()
        write_strokes(tmp_path / "a.doodle", s)
        back = read_strokes(tmp_path / "a.doodle")
        _assert_close(s, back, 1e-8)
        assert back.provenance == s.provenance

    def test_document_matches_design(self):
        doc = stroke_set_to_dict(random_strokes(n_curves=2, n_sq=1))
        assert doc["format"] == "doodle-strokes" and doc["version"] == 1
        assert set(doc["scene"]) >= {"up", "center", "radius", "camera"}
        assert set(doc["scene"]["camera"]) >= {"fov_deg", "distance", "elevation_deg", "width", "height"}
        assert np.array(doc["curves"]["control_points"]).shape == (2, 4, 3)
        assert set(doc["superquadrics"][0]) == {"scale", "shape", "rotation", "translation"}

    def test_unknown_keys_survive(self):
        doc = stroke_set_to_dict(random_strokes(n_curves=1, n_sq=0))
        doc["my_tool"] = {"a": 1}
        doc["scene"]["note"] = "hi"
        doc["curves"]["color"] = "#123456"
        again = json.loads(dumps(loads(json.dumps(doc))))
        assert again["my_tool"] == {"a": 1} and again["scene"]["note"] == "hi" and again["curves"]["color"] == "#123456"

    @pytest.mark.parametrize(
        "mutate,field",
        [
            (lambda d: d.update(version=2), "version"),
            (lambda d: d.update(format="svg"), "format"),
            (lambda d: d["scene"].pop("radius"), "scene.radius"),
            (lambda d: d["scene"].update(radius=-1), "scene.radius"),
            (lambda d: d["curves"]["control_points"][1][2].__setitem__(0, "x"), "curves.control_points[1][2][0]"),
            (lambda d: d["curves"]["control_points"][0].pop(), "curves.control_points[0]"),
            (lambda d: d["superquadrics"][0].update(rotation=[2, 0, 0, 0]), "superquadrics[0].rotation"),
            (lambda d: d["superquadrics"][0].update(shape=[0.05, 1.0]), "superquadrics[0].shape[0]"),
            (lambda d: d["superquadrics"][0].update(scale=[1, 0, 1]), "superquadrics[0].scale[1]"),
            (lambda d: d["scene"]["camera"].update(width=1.5), "scene.camera.width"),
            (lambda d: d["curves"].update(normals=[[[[0, 0, 1]] * 2] * 2] * 2), "curves.normals"),
            (lambda d: d["curves"].update(normals=[[[[0, 0, 2], [0, 0, 1]]] * 2] * 3), "curves.normals[0][0][0]"),
            (lambda d: d["superquadrics"][1].update(outline="no"), "superquadrics[1].outline"),
            (lambda d: d["superquadrics"][1].update(outline_cells=["1" * 16] * 7), "superquadrics[1].outline_cells"),
            (lambda d: d["superquadrics"][0].update(outline_cells=["1" * 15 + "x"] * 8), "superquadrics[0].outline_cells"),
        ],
    )
    def test_errors_name_the_field(self, tmp_path, mutate, field):
        doc = stroke_set_to_dict(random_strokes(n_curves=3, n_sq=2))
        mutate(doc)
        p = tmp_path / "bad.doodle"
        p.write_text(json.dumps(doc))
        with pytest.raises(StrokeFileError) as exc:
            read_strokes(p)
        msg = str(exc.value)
        assert msg.startswith(str(p)) and field in msg and "\n" not in msg

    def test_nan_rejected(self):
        text = dumps(random_strokes(n_curves=1, n_sq=0)).replace('"radius": 1.5', '"radius": NaN')
        with pytest.raises(StrokeFileError, match="NaN"):
            loads(text)

    def test_write_is_atomic(self, tmp_path, monkeypatch):
        p = tmp_path / "keep.doodle"
        write_strokes(p, random_strokes(seed=1))
        before = p.read_bytes()
        import doodle.strokes.files as files

        monkeypatch.setattr(files, "dumps", lambda s: (_ for _ in ()).throw(RuntimeError("boom")))
        with pytest.raises(RuntimeError):
            write_strokes(p, random_strokes(seed=2))
        assert p.read_bytes() == before
        assert [f.name for f in tmp_path.iterdir()] == ["keep.doodle"]


class TestBinary:
    def test_32_curves_8_superquadrics_fit_in_1kb(self):
        assert len(encode(random_strokes(n_curves=32, n_sq=8))) <= 1024

    def test_face_normals_cost_13_bits_an_end_where_both_faces_agree(self):
        """A contour curve's two faces are one (its normal, twice): a flag bit and one 12-bit code an end;
        a crease's two faces: 25 bits."""
        s = random_strokes(n_curves=32, n_sq=8)
        plain = len(encode(s))
        s.curves.normals = np.tile([0.0, 0.0, 1.0], (32, 2, 2, 1))
        assert len(encode(s)) - plain == 32 * 2 * 13 // 8
        s.curves.normals[:, :, 1] = [1.0, 0.0, 0.0]
        assert len(encode(s)) - plain == 32 * 2 * 25 // 8
        assert np.array_equal(decode(encode(s)).curves.normals, s.curves.normals)

    def test_contour_gates_cost_an_index_into_their_palette(self):
        s = random_strokes(n_curves=32, n_sq=8)
        s.curves.normals = np.tile([0.0, 0.0, 1.0], (32, 2, 2, 1))
        plain = len(encode(s))
        s.curves.contour = np.resize([0.0, 0.15, 0.3], 32)
        assert len(encode(s)) - plain == (8 + 3 * 8 + 32 * 2) // 8  # size, three codes, 2 bits a curve
        assert np.abs(decode(encode(s)).curves.gates - s.curves.gates).max() <= 0.5 / 255

    def test_chained_curves_cost_their_shape_not_their_place(self):
        """A joined chain of gently curved cubics: each start is the last end (a bit), chords and handle
        offsets are small numbers: under half the fixed-width 12 coordinates a curve."""
        t = np.linspace(0, 2 * np.pi, 4 * 40 - 39)
        ring = np.stack([np.cos(t), np.sin(t), 0.1 * np.sin(3 * t)], 1)
        s = random_strokes(n_curves=40, n_sq=0)
        s.curves.control_points = np.stack([ring[3 * i:3 * i + 4] for i in range(40)])
        data = encode(s)
        fixed = 40 * 12 * 12 // 8  # 12-bit coordinates
        assert len(data) - len(encode(random_strokes(n_curves=0, n_sq=0))) < 0.5 * fixed
        back = decode(data).curves.control_points
        assert np.abs(back - s.curves.control_points).max() <= 5e-4 * s.frame.radius
        assert np.array_equal(back[1:, 0], back[:-1, 3])  # still joined, exactly

    @pytest.mark.parametrize("name", ["v1", "v2", "v4"])
    def test_files_of_earlier_versions_read_as_written(self, name):
        """Files written by earlier releases (version 1: no flags, 2: every flag, 4: voxel volumes) read back as
        the sets they were written from, and rewritten now decode to the very same numbers."""
        import dataclasses
        from pathlib import Path

        data = (Path(__file__).parent / "data" / f"binary-{name}.doodleb").read_bytes()
        assert data[4] == int(name[1])
        if name == "v1":
            s = random_strokes(seed=11, n_curves=5, n_sq=2)
        elif name == "v2":
            s = random_strokes(seed=12, n_curves=6, n_sq=3, extras=True)
            s.occluder = s.hull = None
            cells = np.ones((3, 8, 16), bool)
            cells[0, 2:4, 5:9] = False
            s.superquadrics = dataclasses.replace(
                s.superquadrics, taper=np.array([[0.3, -0.2], [0, 0], [0, 0]]),
                bend=np.array([[0, 0], [0.4, 0.1], [0, 0]]), outline=np.array([True, False, True]), outline_cells=cells)
        else:
            s = random_strokes(seed=13, n_curves=4, n_sq=1, extras=True)
        old = decode(data)
        _assert_close(s, old, 5e-4 * s.frame.radius, 5.0)
        assert np.abs(old.superquadrics.tapers - s.superquadrics.tapers).max() < 1e-3
        assert np.abs(old.superquadrics.bends - s.superquadrics.bends).max() < 1e-3
        again = encode(old)
        assert again[4] == 5
        new = decode(again)
        assert np.array_equal(new.curves.control_points, old.curves.control_points)
        assert np.array_equal(new.superquadrics.translation, old.superquadrics.translation)
        assert (old.curves.normals is None) or np.array_equal(new.curves.normals, old.curves.normals)
        assert np.array_equal(new.curves.gates, old.curves.gates)
        assert (old.hull is None) or np.array_equal(new.hull.occupied, old.hull.occupied)

    def test_voxel_volumes_travel_as_raw_bits_in_an_xz_trailer(self):
        s = random_strokes(seed=4, extras=True)
        data = encode(s)
        assert data[4] == 5 and data[_FLAGS_AT] & 32
        back = decode(data)
        assert np.array_equal(back.hull.occupied, s.hull.occupied)
        assert np.array_equal(back.occluder.occupied, s.occluder.occupied)
        for bad in (data[:-7], data[:-30] + bytes(30), data + b"\0"):
            with pytest.raises(StrokeFileError):
                decode(bad)

    @pytest.mark.parametrize("seed, radius", [(3, 2.0), (5, 0.01), (7, 300.0)])
    def test_round_trip_within_the_promised_5e_4_of_the_radius(self, seed, radius):
        """Positions and scales within :data:`~doodle.strokes.binary.REL_TOLERANCE` (5·10⁻⁴) of the radius, as
        the format promises, whatever the scene's scale."""
        from doodle.strokes.binary import REL_TOLERANCE

        assert REL_TOLERANCE == 5e-4
        s = random_strokes(seed=seed, radius=radius)
        _assert_close(s, decode(encode(s)), REL_TOLERANCE * radius)

    def test_suffix_selects_binary(self, tmp_path):
        write_strokes(tmp_path / "a.doodleb", random_strokes())
        assert (tmp_path / "a.doodleb").read_bytes()[:4] == b"DDLB"
        assert len(read_strokes(tmp_path / "a.doodleb").curves) == 32


# ---- property-based: valid files round-trip, corrupt ones raise StrokeFileError only -------------------------

finite = st.floats(-50, 50, allow_nan=False, allow_infinity=False)


@st.composite
def stroke_sets(draw):
    n = draw(st.integers(0, 40))
    m = draw(st.integers(0, 10))
    seed = draw(st.integers(0, 2**31))
    radius = draw(st.floats(0.01, 100))
    s = random_strokes(seed=seed, n_curves=n, n_sq=m, radius=radius)
    s.frame.center = np.array([draw(finite), draw(finite), draw(finite)])
    s.curves.control_points = s.curves.control_points + s.frame.center
    s.superquadrics.translation = s.superquadrics.translation + s.frame.center
    rng = np.random.default_rng(seed)
    if n and draw(st.booleans()):
        normals = rng.normal(size=(n, 2, 2, 3))
        normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
        normals[rng.random((n, 2, 2)) < 0.2] = 0.0  # "unknown": never hides
        s.curves.normals = normals
    if n > 1 and draw(st.booleans()):  # joined chains, as a fit writes them
        joined = np.flatnonzero(rng.random(n - 1) < 0.6) + 1
        for i in joined:
            s.curves.control_points[i, 0] = s.curves.control_points[i - 1, 3]
    if s.curves.normals is not None and draw(st.booleans()):
        s.curves.contour = rng.choice(np.linspace(0, 1, draw(st.integers(1, 300))), n)
    if m and draw(st.booleans()):
        s.superquadrics.outline = rng.random(m) < 0.5
    if m and draw(st.booleans()):
        s.superquadrics.outline_cells = rng.random((m, 8, 16)) < 0.8
    return s


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(stroke_sets())
def test_property_valid_files_round_trip(s):
    _assert_close(s, loads(dumps(s)), 1e-6 * max(1.0, float(np.abs(s.frame.center).max()) + s.frame.radius), 0.02)
    back = decode(encode(s))
    _assert_close(s, back, 1e-3 * s.frame.radius, 5.0)  # 6-bit octahedral normals: < 4°
    assert np.abs(back.curves.gates - s.curves.gates).max(initial=0) <= 0.5 / 255 + 1e-12


def _corruptions():
    json_like = st.recursive(
        st.none() | st.booleans() | st.integers(-10**30, 10**30) | st.floats() | st.text(max_size=5),
        lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=4), kids, max_size=4),
        max_leaves=12,
    )
    return json_like


@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_property_corrupt_json_raises_only_stroke_file_error(data):
    doc = stroke_set_to_dict(random_strokes(n_curves=3, n_sq=2))
    text = json.dumps(doc)
    kind = data.draw(st.sampled_from(["truncate", "replace-value", "flip-byte", "huge"]))
    if kind == "truncate":
        text = text[: data.draw(st.integers(0, len(text) - 1))]
    elif kind == "flip-byte":
        i = data.draw(st.integers(0, len(text) - 1))
        text = text[:i] + data.draw(st.characters()) + text[i + 1:]
    elif kind == "huge":
        doc["curves"]["control_points"] = [[[0.0, 0, 0]] * 4] * 70000
        text = json.dumps(doc)
    else:
        path = data.draw(st.sampled_from([("scene", "radius"), ("scene", "up"), ("curves", "control_points"),
                                          ("superquadrics",), ("version",), ("scene", "camera", "fov_deg"),
                                          ("curves", "width_px"), ("provenance",)]))
        target = doc
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = data.draw(_corruptions())
        text = json.dumps(doc)
    try:
        loads(text)
    except StrokeFileError as exc:
        assert "\n" not in str(exc)


@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_property_corrupt_binary_raises_only_stroke_file_error(data):
    raw = bytearray(encode(random_strokes(n_curves=5, n_sq=3)))
    kind = data.draw(st.sampled_from(["truncate", "flip", "append"]))
    if kind == "truncate":
        raw = raw[: data.draw(st.integers(0, len(raw) - 1))]
    elif kind == "flip":
        for _ in range(data.draw(st.integers(1, 8))):
            raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
    else:
        raw += data.draw(st.binary(min_size=1, max_size=20))
    try:
        decode(bytes(raw))
    except StrokeFileError:
        pass


def test_written_files_get_normal_permissions(tmp_path):
    import os
    import stat

    umask = os.umask(0o022)
    try:
        write_strokes(tmp_path / "p.doodle", random_strokes(n_curves=1, n_sq=0))
    finally:
        os.umask(umask)
    assert stat.S_IMODE((tmp_path / "p.doodle").stat().st_mode) == 0o644
