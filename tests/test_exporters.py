import io
import re

import numpy as np
import pytest
import svgelements
from click.testing import CliRunner
from PIL import Image
from scipy import ndimage

from doodle.cameras import Camera, look_at, orbit_cameras
from doodle.cli import cli
from doodle.errors import DoodleError
from doodle.exporters import DrawOptions, ExportOptions, draw, draw_many, export_views, svg_to_array, to_svg
from doodle.exporters.drawing import on_screen_size, piece_length
from doodle.exporters.project import depth_intervals, project_curve
from doodle.strokes import CurveSet, SceneFrame, StrokeSet, SuperquadricSet, write_strokes
from doodle.strokes.bezier import bezier_points

from helpers import random_strokes

I = [1.0, 0.0, 0.0, 0.0]


def _camera(eye, size=512, fov=40.0, target=(0, 0, 0)):
    R, t = look_at(np.asarray(eye, float), np.asarray(target, float), np.array([0, 0, 1.0]))
    f = 0.5 * size / np.tan(np.radians(fov) / 2)
    return Camera(f, f, size / 2, size / 2, size, size, R, t, name="test")


def _strokes(curves=None, sq=None, radius=1.0):
    return StrokeSet(SceneFrame(radius=radius), CurveSet(np.asarray(curves if curves is not None else np.zeros((0, 4, 3)), float)),
                     sq if sq is not None else SuperquadricSet())


def _paths(svg_text):
    doc = svgelements.SVG.parse(io.StringIO(svg_text), reify=True)
    return {e.id: e for e in doc.elements() if isinstance(e, svgelements.Path)}, doc


class TestCurveProjection:
    def test_orthographic_is_exactly_the_projected_control_points(self):
        s = random_strokes(n_curves=5, n_sq=0)
        cam = orbit_cameras(s.frame, 1, width=512, projection="orthographic")[0]
        svg = to_svg(draw(s, cam, DrawOptions(silhouettes=False)))
        paths, _ = _paths(svg)
        for n, control in enumerate(s.curves.control_points):
            seg = [x for x in paths[f"curve-{n:03d}"] if isinstance(x, svgelements.CubicBezier)]
            assert len(seg) == 1
            got = np.array([[p.x, p.y] for p in (seg[0].start, seg[0].control1, seg[0].control2, seg[0].end)])
            want, _ = cam.project(control)
            assert np.abs(got - want).max() <= 0.005 + 1e-9

    @pytest.mark.parametrize("seed", range(12))
    def test_perspective_within_tolerance(self, seed):
        rng = np.random.default_rng(seed)
        # near cameras and long curves that span (and leave) the view are the hard cases
        dist = rng.uniform(1.4, 5.0)
        eye = rng.normal(size=3)
        eye = dist * eye / np.linalg.norm(eye)
        cam = _camera(eye, size=512, fov=rng.uniform(30, 90))
        control = rng.uniform(-1.2, 1.2, (4, 3))
        tol = 0.05
        for a, b in depth_intervals(control, cam, 1e-3):
            pieces, breaks = project_curve(control, cam, a, b, tol, return_breaks=True)
            s = np.linspace(0, 1, 101)
            for piece, t0, t1 in zip(pieces, breaks[:-1], breaks[1:]):
                truth, _ = cam.project(bezier_points(control, t0 + s * (t1 - t0)))
                assert np.linalg.norm(bezier_points(piece, s) - truth, axis=1).max() <= tol * 1.001

    def test_curve_through_the_near_plane_is_clipped(self):
        cam = _camera([3.0, 0, 0])
        control = np.array([[-1.0, 0.1, 0.0], [1.0, 0.1, 0.0], [4.0, 0.1, 0.1], [6.0, 0.1, 0.2]])  # passes the eye
        iv = depth_intervals(control, cam, 1e-3)
        assert len(iv) == 1 and iv[0][0] == 0.0 and 0 < iv[0][1] < 1
        z = (bezier_points(control, np.array([iv[0][1]])) @ cam.R.T + cam.t)[0, 2]
        assert z == pytest.approx(1e-3, abs=1e-9)
        d = draw(_strokes([control]), cam, DrawOptions(silhouettes=False))
        pts = np.concatenate([p.reshape(-1, 2) for op in d.paths for p in op.subpaths])
        assert np.isfinite(pts).all()


class TestHiddenLines:
    def _scene(self):
        sphere = SuperquadricSet(np.array([[0.5, 0.5, 0.5]]), np.ones((1, 2)), np.array([I]), np.zeros((1, 3)))
        behind = [[[-1.5, -1.0, 0.0], [-0.5, -1.0, 0.0], [0.5, -1.0, 0.0], [1.5, -1.0, 0.0]]]  # y = -1: behind from +y
        return _strokes(behind, sphere), _camera([0, 4.0, 0.0])

    @pytest.mark.parametrize("mode,vis_subpaths,hidden_paths", [("hide", 2, 0), ("dash", 2, 1), ("show", 1, 0)])
    def test_curve_behind_a_sphere(self, mode, vis_subpaths, hidden_paths):
        s, cam = self._scene()
        d = draw(s, cam, DrawOptions(hidden=mode))
        (curve,) = [p for p in d.paths if p.id == "curve-000"]
        assert len(curve.subpaths) == vis_subpaths
        assert len([p for p in d.layer("hidden") if p.id == "hidden-curve-000"]) == hidden_paths
        if mode != "show":  # the gap is where the sphere covers the line: |x| < ~0.5·(5/4) projected
            ends = [sp[-1, -1, 0] for sp in curve.subpaths] + [sp[0, 0, 0] for sp in curve.subpaths]
            u_center, _ = cam.project(np.zeros((1, 3)))
            gap = sorted(abs(e - u_center[0, 0]) for e in ends)[:2]
            half_width = 0.5 * cam.fx / np.sqrt(4.0**2 - 0.25)
            assert all(abs(g - half_width * 1.25) < 0.35 * half_width for g in gap)

    def test_silhouette_behind_other_superquadric_hidden(self):
        sq = SuperquadricSet(np.array([[0.5, 0.5, 0.5], [0.2, 0.2, 0.2]]), np.ones((2, 2)), np.array([I, I]),
                             np.array([[0, 0, 0], [0, -0.9, 0]]))  # small ball right behind the big one
        cam = _camera([0, 4.0, 0.0])
        hide = draw(_strokes(None, sq), cam, DrawOptions(hidden="hide"))
        dash = draw(_strokes(None, sq), cam, DrawOptions(hidden="dash"))
        assert not any(p.id.startswith("silhouette-001") for p in hide.paths)
        assert any(p.id.startswith("hidden-silhouette-001") for p in dash.layer("hidden"))


class TestStubs:
    """Pieces shorter than ``DrawOptions.min_piece`` of the object's on-screen size, and marks (pieces with all
    that touch them) smaller than ``DrawOptions.min_mark``, are dots and ticks: not drawn."""

    def test_a_curve_seen_end_on_is_no_dot(self):
        cam = _camera([0, 4.0, 0.0])
        end_on = [[[0.05, 0.5, 0.0], [0.05, 0.2, 0.0], [0.05, -0.2, 0.0], [0.05, -0.5, 0.0]]]  # along the view
        size = on_screen_size(cam, SceneFrame(radius=1.0))
        assert 300 < size < 400  # 2 · f · r / distance, about
        drawn = draw(_strokes(end_on), cam, DrawOptions(min_piece=0.0, min_mark=0.0))
        (piece,) = [sp for op in drawn.paths for sp in op.subpaths]
        assert 0 < piece_length(piece) < DrawOptions().min_piece * size  # a dot at the default
        assert not [op for op in draw(_strokes(end_on), cam).paths if op.subpaths]

    def test_a_stub_peeking_out_from_behind_a_part_is_left_out(self):
        sphere = SuperquadricSet(np.array([[0.5, 0.5, 0.5]]), np.ones((1, 2)), np.array([I]), np.zeros((1, 3)))
        behind = [[[-0.85, -1.0, 0.0], [0.0, -1.0, 0.0], [0.8, -1.0, 0.0], [1.6, -1.0, 0.0]]]  # peeks out on the left
        s, cam = _strokes(behind, sphere), _camera([0, 4.0, 0.0])
        every = draw(s, cam, DrawOptions(min_piece=0.0))
        lengths = sorted(piece_length(sp) for op in every.paths if op.id == "curve-000" for sp in op.subpaths)
        assert len(lengths) == 2 and lengths[0] < 0.5 * lengths[1]
        size = on_screen_size(cam, s.frame)
        cut = draw(s, cam, DrawOptions(min_piece=0.5 * (lengths[0] + lengths[1]) / size))
        kept = [piece_length(sp) for op in cut.paths if op.id == "curve-000" for sp in op.subpaths]
        assert kept == pytest.approx([lengths[1]])
        assert not [op for op in draw(s, cam, DrawOptions(min_piece=0.9)).paths if op.id == "curve-000"]

    def test_the_object_behind_the_camera_gives_no_size(self):
        cam = _camera([0, 4.0, 0.0])
        assert on_screen_size(cam, SceneFrame(center=np.array([0, 9.0, 0]), radius=1.0)) == 0.0
        with pytest.raises(DoodleError, match="min_piece"):
            draw(_strokes([[[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0]]]), cam, DrawOptions(min_piece=-0.1))

    def test_an_isolated_tick_is_left_out_but_short_pieces_that_make_a_line_or_a_corner_stay(self):
        def line(a, b):
            a, b = np.asarray(a, float), np.asarray(b, float)
            return [a, a + (b - a) / 3, a + 2 * (b - a) / 3, b]

        cam = _camera([0, 4.0, 0.0])
        size = on_screen_size(cam, SceneFrame(radius=1.0))
        short = 0.03  # world units: about 5 px, above min_piece's 1 % and under min_mark's 2 % of ~350 px
        curves = [line([-0.6, 0, 0], [0.6, 0, 0]),  # 0: a long edge
                  line([0.0, 0, 0.5], [short, 0, 0.5]),  # 1: a tick alone
                  line([0.6, 0, 0], [0.6, 0, short])]  # 2: a short piece at the edge's end: a corner
        # 3-6: a chain of four short pieces end to end
        curves += [line([-0.5 + k * short, 0, -0.5], [-0.5 + (k + 1) * short, 0, -0.5]) for k in range(4)]
        s = _strokes(curves)
        lengths = {op.id: piece_length(op.subpaths[0]) for op in draw(s, cam, DrawOptions(min_mark=0.0)).paths}
        assert len(lengths) == 7
        assert DrawOptions().min_piece * size < lengths["curve-001"] < DrawOptions().min_mark * size
        kept = {op.id for op in draw(s, cam).paths}
        assert kept == {f"curve-{k:03d}" for k in (0, 2, 3, 4, 5, 6)}
        # the chain is one mark of 4 × 5 px: a threshold above its extent leaves it out whole
        chain = _strokes(curves[3:])
        assert not draw(chain, cam, DrawOptions(min_mark=5 * lengths["curve-003"] / size)).paths
        assert len(draw(chain, cam, DrawOptions(min_mark=3 * lengths["curve-003"] / size)).paths) == 4
        with pytest.raises(DoodleError, match="min_mark"):
            draw(s, cam, DrawOptions(min_mark=1.0))

    def test_cli_min_piece(self, tmp_path):
        s = random_strokes(n_curves=6, n_sq=1)
        write_strokes(tmp_path / "s.doodle", s)
        ok = CliRunner().invoke(cli, ["export", str(tmp_path / "s.doodle"), "-o", str(tmp_path / "v"), "--views", "2",
                                      "--min-piece", "0", "--min-mark", "0.05"])
        assert ok.exit_code == 0, ok.output
        bad = CliRunner().invoke(cli, ["export", str(tmp_path / "s.doodle"), "-o", str(tmp_path / "w"), "--views", "2",
                                       "--min-piece", "1.5"])
        assert bad.exit_code == 2 and "--min-piece" in bad.output and "[0, 1)" in bad.output
        assert not (tmp_path / "w").exists()
        bad = CliRunner().invoke(cli, ["animate", str(tmp_path / "s.doodle"), "--gif", str(tmp_path / "a.gif"),
                                       "--min-mark", "-1"])
        assert bad.exit_code == 2 and "--min-mark" in bad.output and not (tmp_path / "a.gif").exists()


GOLD = (np.sqrt(5) - 1) / 2


def _first_hits(sq, cam, iterations: int = 40) -> np.ndarray:
    """Each pixel ray's first hit with one convex superquadric ``sq`` (e1, e2 ≤ 2): ``(H, W)`` depths, inf where
    it misses; exact to ~1e-8 of the ray's chord. log f is quasi-convex along a line (its level sets are convex
    bodies), so a golden-section search finds its minimum on the ray's chord through the bounding sphere (below
    0: the ray enters), and bisection on [chord start, minimum], where it only falls, finds where it crosses 0.
    (Marching 256 steps a ray missed grazing rays at pinched edges and took 2.5-8 times as long.)"""
    from doodle.strokes.superquadric import log_inside_outside, quaternion_to_matrix

    o, d = cam.rays()
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    c, r = sq.translation[0], float(np.linalg.norm(sq.scale[0]))
    b = ((c - o) * d).sum(1)
    h2 = r * r - ((c - o) ** 2).sum(1) + b * b
    k = np.nonzero(h2 > 0)[0]
    h = np.sqrt(h2[k])
    R = quaternion_to_matrix(sq.rotation)[0]
    ol, dl = (o[k] - c) @ R, d[k] @ R  # the local frame: x = Rᵀ (p − c)

    def f(t, ol=ol, dl=dl):
        return log_inside_outside((ol + t[:, None] * dl)[None], sq.scale, sq.shape)[0]

    a, z = np.maximum(b[k] - h, 0.0), b[k] + h
    x1, x2 = z - GOLD * (z - a), a + GOLD * (z - a)
    f1, f2 = f(x1), f(x2)
    for _ in range(iterations):
        left = f1 < f2  # the minimum lies in [a, x2] (x1 becomes the new x2), else in [x1, z] (x2 the new x1)
        z, a = np.where(left, x2, z), np.where(left, a, x1)
        x1n, x2n = np.where(left, z - GOLD * (z - a), x2), np.where(left, x1, a + GOLD * (z - a))
        fn = f(np.where(left, x1n, x2n))
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        x1, x2 = x1n, x2n
    t_min = 0.5 * (x1 + x2)
    hit = f(t_min) < 0
    lo, hi = np.maximum(b[k] - h, 0.0)[hit], t_min[hit]
    ol, dl = ol[hit], dl[hit]
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        inside = f(mid, ol, dl) < 0
        hi, lo = np.where(inside, mid, hi), np.where(inside, lo, mid)
    out = np.full(len(o), np.inf)
    out[k[hit]] = hi
    return out.reshape(cam.height, cam.width)


def _reference(sq, cam):
    """Mask boundary, and mask boundary ∪ depth discontinuities (visible interior occluding contours), from each
    pixel's exact first hit with the union."""
    best = np.minimum.reduce([_first_hits(sq.subset([j]), cam) for j in range(len(sq))])
    m = np.isfinite(best)
    bd = m ^ ndimage.binary_erosion(m)
    finite = np.where(m, best, 1e3)
    jumps = ndimage.maximum_filter(finite, 3) - ndimage.minimum_filter(finite, 3) > 0.05
    return bd, bd | (jumps & m)


def _silhouette_samples(drawing):
    pts = []
    for op in drawing.layer("silhouettes"):
        for sp in op.subpaths:
            for seg in sp:
                n = int(4 * np.abs(np.diff(seg, axis=0)).sum()) + 8
                pts.append(bezier_points(seg, np.linspace(0, 1, n)))
    return np.concatenate(pts) if pts else np.zeros((0, 2))


#: The range's corners and middles: (1.9, 1.0)'s pinched outline once drew a 200 px loop (a fitted handle far
#: longer than its piece when exact tangents turn sharply between two vertices).
SHAPES = [(e1, e2) for e1 in (0.1, 0.5, 1.0, 1.5, 1.9) for e2 in (0.1, 1.0, 1.9)]


class TestSilhouetteAccuracy:
    def _check(self, sq, cam, need_precision=0.98, need_recall=0.95):
        bd, bd_all = _reference(sq, cam)
        d = draw(_strokes(None, sq), cam, DrawOptions(curves=False))
        pts = _silhouette_samples(d)
        u = np.clip(np.floor(pts).astype(int), 0, cam.width - 1)
        near_ref = ndimage.distance_transform_edt(~bd_all) <= 1.0 + 0.5  # pixel centres vs pixel-precise mask
        precision = near_ref[u[:, 1], u[:, 0]].mean()
        stroke = np.zeros(bd.shape, bool)
        stroke[u[:, 1], u[:, 0]] = True
        recall = (ndimage.distance_transform_edt(~stroke)[bd] <= 1.5).mean()
        assert precision >= need_precision and recall >= need_recall, (precision, recall)

    @pytest.mark.parametrize("e1,e2", SHAPES)
    def test_single_superquadric(self, e1, e2):
        q = np.array([0.95, 0.2, -0.1, 0.2])
        sq = SuperquadricSet(np.array([[0.6, 0.4, 0.3]]), np.array([[e1, e2]]), np.array([q / np.linalg.norm(q)]),
                             np.array([[0.05, -0.05, 0.0]]))
        self._check(sq, _camera([2.6, 1.6, 1.4]))

    @pytest.mark.parametrize("seed", [0, 1, 2])
    def test_overlapping_unions(self, seed):
        rng = np.random.default_rng(seed)
        q = rng.normal(size=(3, 4))
        sq = SuperquadricSet(rng.uniform(0.2, 0.5, (3, 3)), rng.uniform(0.1, 1.9, (3, 2)),
                             q / np.linalg.norm(q, axis=1, keepdims=True), rng.uniform(-0.3, 0.3, (3, 3)))
        self._check(sq, _camera([2.4, -1.9, 1.5]))


class TestSvgDocument:
    def test_structure_ids_and_metadata(self):
        s = random_strokes(n_curves=4, n_sq=2)
        svg = to_svg(draw(s, orbit_cameras(s.frame, 1, width=300, height=200)[0], DrawOptions(hidden="dash")), source="x.doodle")
        assert 'viewBox="0,0,300,200"' in svg and 'width="300px"' in svg and 'height="200px"' in svg
        for layer in ("curves", "silhouettes", "hidden"):
            assert f'inkscape:label="{layer}"' in svg
        assert 'inkscape:groupmode="layer"' in svg and 'stroke-linecap="round"' in svg and 'fill="none"' in svg
        assert re.search(r'id="curve-00\d"', svg) and re.search(r'id="silhouette-00\d-\d"', svg)
        assert "<metadata" in svg and "x.doodle" in svg and '"fx"' in svg
        assert "<script" not in svg and "href" not in svg
        paths, doc = _paths(svg)
        assert doc.viewbox.width == 300 and len(paths) > 4

    def test_deterministic_bytes(self):
        """The same strokes and camera give the same SVG bytes, in this process and in a fresh one."""
        from helpers import in_a_fresh_process

        code = ("import sys; from helpers import random_strokes; from doodle.cameras import orbit_cameras; "
                "from doodle.exporters import draw, to_svg; s = random_strokes(n_curves=6, n_sq=3); "
                "sys.stdout.write(to_svg(draw(s, orbit_cameras(s.frame, 3, width=256)[1])))")
        s = random_strokes(n_curves=6, n_sq=3)
        here = to_svg(draw(s, orbit_cameras(s.frame, 3, width=256)[1]))
        assert here == to_svg(draw(random_strokes(n_curves=6, n_sq=3), orbit_cameras(s.frame, 3, width=256)[1]))
        assert here.encode() == in_a_fresh_process(code)

    @pytest.mark.parametrize("hidden", ["hide", "dash"])
    def test_batch_of_views_draws_what_each_view_draws(self, hidden):
        """draw_many (one occlusion query, one fit, one projection for all views) changes no byte."""
        s = random_strokes(n_curves=8, n_sq=4)
        cams = orbit_cameras(s.frame, 4, width=256) + orbit_cameras(s.frame, 2, width=200, projection="orthographic")
        opt = DrawOptions(hidden=hidden)
        assert [to_svg(d) for d in draw_many(s, cams, opt)] == [to_svg(draw(s, c, opt)) for c in cams]

    def test_cairosvg_renders_strokes(self):
        s = random_strokes(n_curves=6, n_sq=3)
        img = svg_to_array(to_svg(draw(s, orbit_cameras(s.frame, 1, width=256)[0])))
        assert img.shape == (256, 256, 4) and (img[..., :3].mean(-1) < 128).sum() > 200


class TestExportFunctionAndCli:
    def test_export_views_writes_every_format(self, tmp_path):
        s = random_strokes(n_curves=4, n_sq=1)
        cams = orbit_cameras(s.frame, 3, width=128)
        files = export_views(s, cams, tmp_path / "out", ExportOptions(png=True, pdf=True, sheet=tmp_path / "sheet.png"))
        names = sorted(f.name for f in files)
        assert names == sorted([f"view_{k:03d}.{e}" for k in range(3) for e in ("svg", "png", "pdf")] + ["sheet.png"])
        assert Image.open(tmp_path / "sheet.png").size[0] >= 256
        assert (tmp_path / "out" / "view_000.pdf").read_bytes()[:4] == b"%PDF"
        assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith(".")]

    def test_cli_36_views(self, tmp_path):
        p = tmp_path / "s.doodle"
        write_strokes(p, random_strokes(n_curves=3, n_sq=1))
        r = CliRunner().invoke(cli, ["export", str(p), "--svg", "--views", "36", "-o", str(tmp_path / "o"), "--size", "64"])
        assert r.exit_code == 0, r.output
        assert len(list((tmp_path / "o").glob("view_*.svg"))) == 36

    def test_cli_dataset_cameras(self, tmp_path, chair_dir):
        p = tmp_path / "s.doodle"
        write_strokes(p, random_strokes(n_curves=3, n_sq=0))
        r = CliRunner().invoke(cli, ["export", str(p), "--cameras", str(chair_dir), "--split", "test", "-o", str(tmp_path / "o")])
        assert r.exit_code == 0, r.output
        assert len(list((tmp_path / "o").glob("*.svg"))) == 4

    @pytest.mark.parametrize("case", ["views0", "inside", "empty", "corrupt", "size"])
    def test_bad_input_one_line_exit_2_nothing_written(self, tmp_path, case):
        s = random_strokes(n_curves=3, n_sq=1)
        args = ["--views", "4"]
        if case == "views0":
            args = ["--views", "0"]
        elif case == "inside":
            s.frame.camera.distance = 0.01
        elif case == "empty":
            s = _strokes()
        elif case == "size":
            args = ["--size", "12xfoo"]
        p = tmp_path / "s.doodle"
        write_strokes(p, s)
        if case == "corrupt":
            p.write_text('{"format": "doodle-strokes"')
        out = tmp_path / "o"
        out.mkdir()
        (out / "keep.svg").write_text("mine")
        r = CliRunner().invoke(cli, ["export", str(p), "-o", str(out), *args])
        assert r.exit_code == 2, r.output
        assert "Traceback" not in r.output and r.output.strip().count("\n") == 0 and r.output.startswith("Error: ")
        assert sorted(x.name for x in out.iterdir()) == ["keep.svg"] and (out / "keep.svg").read_text() == "mine"


@pytest.mark.parametrize("azimuth", [0.0, 90.0, 180.0, 270.0])
def test_box_contour_closes_across_the_parameter_seam(azimuth):
    """sin(π) is 1e-16, not 0: a box-like superquadric's contour must still close at ω = ±π."""
    from doodle.exporters.silhouettes import contour_polylines

    sq = SuperquadricSet(np.array([[0.45, 0.45, 0.06]]), np.array([[0.1, 0.1]]), np.array([I]), np.zeros((1, 3)))
    a = np.radians(azimuth)
    polys = contour_polylines(sq, _camera([3 * np.cos(a), 3 * np.sin(a), 1.7]))
    assert len(polys) == 1 and np.allclose(polys[0][1][0], polys[0][1][-1])


def test_outline_cells_leave_out_the_contour_where_a_fit_did_not_confirm_it():
    """A ball whose lower four latitude bands are left out draws its outline only above its centre; all cells
    on draws what no cells field draws; all off draws nothing (the ball still hides what is behind it)."""
    ball = SuperquadricSet(np.array([[0.6, 0.6, 0.6]]), np.array([[1.0, 1.0]]), np.array([I]), np.zeros((1, 3)))
    cam = _camera([3.0, 0.5, 0.3])
    frame = SceneFrame(radius=1.0)

    def outline(cells):
        ball.outline_cells = cells
        d = draw(StrokeSet(frame, CurveSet(), ball), cam, DrawOptions(tolerance=0.1))
        return np.concatenate([op.points() for op in d.layer("silhouettes")] or [np.zeros((0, 2))])

    whole = outline(None)
    assert np.array_equal(outline(np.ones((1, 8, 16), bool)), whole)
    upper = np.ones((1, 8, 16), bool)
    upper[0, :4] = False  # latitudes below the equator
    centre_y = cam.project(np.zeros((1, 3)))[0][0, 1]
    top = outline(upper)
    assert len(top) > 0.3 * len(whole) and (top[:, 1] < centre_y + 1.0).all()  # image y grows downward
    assert len(outline(np.zeros((1, 8, 16), bool))) == 0
