"""Stage 2, volume: carve the visual hull once from the masks (:mod:`doodle.fit.volume.carve`), at the evidence
size, and take from it what the file and the later stages need: the hull whose outline ``--outline hull``
draws and the occluder that hides what lies behind the object's bulk (on a coarser grid). Discovery votes on
this carving's grid, the abstraction fits superquadrics to it, the silhouette fit takes its thick part, the
gradient path starts inside it. Without masks there is no volume (and nothing to do)."""

from __future__ import annotations

from ..state import Carving, FitState
from ..volume.carve import carve_hull
from ..volume.hull import hull_occluder, occluder_voxels, outline_hull

NAME = "volume"


def run(state: FitState) -> None:
    cfg = state.config
    if not state.plan.masks:
        return
    if state.carving is None:
        carving = state.shared.get("carving")
        if carving is None:
            carving = Carving(*carve_hull(state.evidence, cfg.evidence_voxels))
            state.shared["carving"] = carving
        state.carving = carving
    if cfg.use_occluder and state.occluder is None:
        state.occluder = hull_occluder(state.carving.grid, state.carving.occupied, occluder_voxels(cfg.size))
    if cfg.outline_hull and state.hull is None:
        state.hull = outline_hull(state.carving.grid, state.carving.occupied)
