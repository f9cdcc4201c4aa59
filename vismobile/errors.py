"""The user-facing error types: each names the file (and line) it is about."""


class VisMobileError(Exception):
    """Base of every error the CLI reports as one line with exit code 2."""


class WorldError(VisMobileError):
    """An OBJ world that cannot be loaded: missing, empty, malformed or degenerate."""

    def __init__(self, path, message, line=None):
        self.path, self.line = str(path), line
        where = f"{path}:{line}" if line is not None else f"{path}"
        super().__init__(f"{where}: {message}")


class PartitionError(VisMobileError):
    """A partition file that is corrupt, truncated, of another format or of a newer version."""


class ProfileError(VisMobileError):
    """A world, camera or budget that the device profile or arithmetic mode cannot represent."""


class TrajectoryError(VisMobileError):
    """A trajectory file that cannot be read."""


class OutputError(VisMobileError):
    """An output path that cannot be written: a directory, device, a path under a file, a
    read-only or full file system."""

    def __init__(self, path, message):
        self.path = str(path)
        super().__init__(f"{path}: {message}")


def one_line(text) -> str:
    """text with control characters escaped (a newline in a file name stays one line)."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))
