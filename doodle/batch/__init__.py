"""Many objects: ``doodle batch`` over a manifest, resumable, on local processes or a Ray cluster."""

from .manifest import OPTIONS, BatchObject, Manifest, load_manifest
from .runner import BatchOptions, BatchResult, run_batch

__all__ = ["OPTIONS", "BatchObject", "BatchOptions", "BatchResult", "Manifest", "load_manifest", "run_batch"]
