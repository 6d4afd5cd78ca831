"""Exceptions carrying the C API's status and its one-line message.

Every failing call of libhaha_runtime.so returns a ``haha_status`` and leaves one line in
``haha_last_error()`` naming the file or the call (``avatar.glb: gaussians: checksum
mismatch``); the package raises the matching exception with that line as its message.
"""


class HahaError(Exception):
    """Base of every error the package raises; ``status`` is the C API's status name."""

    status = "HAHA_ERROR_INTERNAL"

    def __init__(self, message, status=None):
        super().__init__(message)
        if status is not None:
            self.status = status


class ArgumentError(HahaError, ValueError):
    """A bad argument: wrong pose shape, non-finite values, a buffer or option that cannot be honoured."""

    status = "HAHA_ERROR_ARGUMENT"


class FileError(HahaError, OSError):
    """A file could not be opened, read or written (HAHA_ERROR_IO)."""

    status = "HAHA_ERROR_IO"

    def __str__(self):  # OSError would format its arguments as a tuple
        return self.args[0] if self.args else ""


class FormatError(HahaError, ValueError):
    """A file's contents are invalid: not a .glb / .npz, truncated, checksum mismatch (HAHA_ERROR_FORMAT)."""

    status = "HAHA_ERROR_FORMAT"


class StateError(HahaError, RuntimeError):
    """Wrong call order, e.g. rendering a pose state never reposed (HAHA_ERROR_STATE)."""

    status = "HAHA_ERROR_STATE"


class OutOfMemoryError(HahaError, MemoryError):
    """The library ran out of memory (HAHA_ERROR_OUT_OF_MEMORY)."""

    status = "HAHA_ERROR_OUT_OF_MEMORY"


class InternalError(HahaError, RuntimeError):
    """Anything else: a bug in the library (HAHA_ERROR_INTERNAL)."""

    status = "HAHA_ERROR_INTERNAL"


class LibraryNotFoundError(HahaError, ImportError):
    """libhaha_runtime.so could not be found or loaded, or its version does not match."""

    status = "library"


# haha_status value -> exception class (runtime/include/haha/haha_runtime.h).
STATUS_ERRORS = {
    1: ArgumentError,
    2: FileError,
    3: FormatError,
    4: StateError,
    5: OutOfMemoryError,
    6: InternalError,
}
