"""``doodle demo``: the whole pipeline on a built-in procedural scene, end to end."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Callable

from .animate import AnimateOptions, animate
from .atomic import write_text
from .evaluate import evaluate
from .exporters import ExportOptions, export_cameras, export_views
from .fit import FitConfig, fit
from .samples import write_sample
from .scenes import load_scene
from .strokes import write_strokes

DEMO_SCENE = "snowman"


def run_demo(out_dir: str | Path = "doodle-demo", scene: str = DEMO_SCENE, config: FitConfig | None = None,
             log: Callable[[str], None] = print, progress: bool = True, train: int = 40, test: int = 10,
             size: int = 256) -> dict[str, Path]:
    """Render a sample scene (``train`` + ``test`` views at ``size`` px), fit it, export 36 SVG views, a
    contact sheet, a turntable GIF and the held-out metrics.

    Returns:
        The paths written, by name.
    """
    out = Path(out_dir)
    start = time.perf_counter()
    scene_dir = write_sample(scene, out / "scene", n_train=train, n_test=test, size=size, force=True)
    log(f"1/4 rendered the procedural '{scene}' scene into {scene_dir}")
    result = fit(load_scene(scene_dir), config or FitConfig(), log=lambda m: log(f"    {m}"), progress=progress)
    if result.interrupted:
        raise KeyboardInterrupt
    strokes_path = out / "strokes.doodle"
    write_strokes(strokes_path, result.strokes)
    log(f"2/4 fitted {len(result.strokes.curves)} curves + {len(result.strokes.superquadrics)} superquadrics "
        f"in {result.seconds:.0f} s → {strokes_path}")
    cams = export_cameras(result.strokes, views=36, size=(512, None))
    files = export_views(result.strokes, cams, out / "views", ExportOptions(sheet=out / "sheet.png", source=str(strokes_path)))
    log(f"3/4 exported {len(files) - 1} SVG views → {out / 'views'} and a contact sheet → {out / 'sheet.png'}")
    paths = {"scene": scene_dir, "strokes": strokes_path, "views": out / "views", "sheet": out / "sheet.png"}
    gif = out / "turntable.gif"
    animate(result.strokes, gif, AnimateOptions(frames=36, size=384))
    paths["gif"] = gif
    log(f"    turntable animation → {gif}")
    metrics = evaluate(result.strokes, load_scene(scene_dir, split="test"))
    write_text(out / "metrics.json", json.dumps({k: v for k, v in metrics.items() if k != "per_view"}, indent=1))
    paths["metrics"] = out / "metrics.json"
    log(f"4/4 held-out views: line precision {metrics['line_precision']:.2f}, silhouette recall "
        f"{metrics['silhouette_recall']:.2f}, F {metrics['f_score']:.2f} → {out / 'metrics.json'}")
    log(f"done in {time.perf_counter() - start:.0f} s; open {out / 'sheet.png'} or {out / 'views' / 'view_000.svg'}")
    return paths
