"""Error types. Every user-facing failure is a :class:`DoodleError` whose message is one line that
names the offending file or field; the CLI prints it and exits with status 2."""


class DoodleError(Exception):
    """Base class for errors caused by user input (bad files, bad options)."""


class StrokeFileError(DoodleError):
    """A ``.doodle`` stroke file (JSON or binary) is malformed."""


class SceneError(DoodleError):
    """A scene folder (NeRF-synthetic, nerfstudio, COLMAP, photos) cannot be loaded."""
