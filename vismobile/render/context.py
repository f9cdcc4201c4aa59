"""The headless OpenGL context (EGL; Mesa llvmpipe where there is no GPU) and render targets."""
from __future__ import annotations

from ..errors import VisMobileError

_CONTEXT = None
_TARGETS = {}  # (size, kind) -> framebuffer, most recently used last
# Sizes kept per kind: a window resized through many sizes must not keep a target for each.
TARGETS_KEPT = 4


class RenderError(VisMobileError):
    """No usable OpenGL context, or a GL object that could not be created."""


def gl_context():
    """The process's one moderngl standalone context (EGL backend), created on first use.

    Raises RenderError with the backend's message when EGL or OpenGL 3.3 is unavailable.
    """
    global _CONTEXT
    if _CONTEXT is None:
        try:
            import moderngl
        except ImportError as error:
            raise RenderError(f"moderngl is not installed ({error})") from None
        try:
            ctx = moderngl.create_standalone_context(backend="egl", require=330)
        except Exception as error:  # moderngl raises plain Exception subclasses per backend
            raise RenderError(
                "cannot create a headless OpenGL 3.3 context through EGL "
                f"({type(error).__name__}: {error}); install Mesa's EGL (libegl1, "
                "libgl1-mesa-dri) or run where a GPU driver provides EGL") from None
        ctx.gc_mode = "auto"  # GL objects die with their Python wrappers
        _CONTEXT = ctx
    return _CONTEXT


def render_target(size, kind):
    """Cached framebuffer of size (width, height): kind "rgb" (RGBA8) or "ids" (R32UI), + depth;
    the TARGETS_KEPT most recently used sizes of each kind are kept, older ones freed.

    Both kinds use the same 24-bit depth renderbuffer format, so they rasterise alike.
    """
    key = (tuple(size), kind)
    target = _TARGETS.pop(key, None)
    if target is None:
        ctx = gl_context()
        if kind == "rgb":
            color = ctx.renderbuffer(size, components=4, dtype="f1")
        elif kind == "ids":
            color = ctx.renderbuffer(size, components=1, dtype="u4")
        else:
            raise ValueError(f"unknown render target kind {kind!r}")
        target = ctx.framebuffer([color], ctx.depth_renderbuffer(size))
        same_kind = [k for k in _TARGETS if k[1] == kind]
        for old in same_kind[:max(0, len(same_kind) - TARGETS_KEPT + 1)]:
            del _TARGETS[old]  # least recently used; gc_mode "auto" frees its GL objects
    _TARGETS[key] = target
    return target



def make_current() -> None:
    """Make the headless context current on this thread (created here on first use). A thread
    has one current context across GLX and EGL: a window's context must be released first."""
    gl_context().__enter__()


def release_current() -> None:
    """Leave no EGL context current on this thread, so a window's context can take its place."""
    egl = _egl_library()
    display = egl.eglGetCurrentDisplay()
    if display:
        egl.eglMakeCurrent(display, None, None, None)


def _egl_library():
    import ctypes
    from ctypes.util import find_library

    egl = ctypes.CDLL(find_library("EGL") or "libEGL.so.1")
    egl.eglGetCurrentDisplay.restype = ctypes.c_void_p
    egl.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
    return egl
