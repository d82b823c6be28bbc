"""Denoising the final render with OpenImageDenoise, the library Blender itself ships.

Render › Sampling › Denoise works as Cycles' OpenImageDenoise denoiser: the Combined pass is
denoised with the Denoising Albedo and Denoising Normal passes the renderer writes as guides,
and the noisy image is kept in the "Noisy Image" pass. The denoiser is Intel Open Image
Denoise's "RT" filter (Áfra et al., a convolutional network trained on path-traced images);
nothing of it is written here: the library is called through `ctypes` from the folder of the
running Blender (or of the bpy module), so the add-on needs no dependency of its own.

The guides are prefiltered as Cycles' settings name it: "Accurate" (the default) denoises the
albedo and the normal with their own RT filters first and then tells the colour filter they are
clean; "Fast" hands the noisy guides to the colour filter as noisy; "None" hands them over as
clean. The colour is linear HDR.

No bpy here (the engine passes the paths and the render layer), so this module is tested on
its own. A missing library raises `DenoiserMissing` naming every place looked at, a failing one
`DenoiseError` with the library's own message; the engine shows either as a warning and keeps
the noisy image.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
from pathlib import Path

import numpy as np

ENV_VAR = "PHOTON_OIDN_LIBRARY"
PREFILTERS = ("NONE", "FAST", "ACCURATE")

# The C API's enumerations (oidn.h, OpenImageDenoise 2).
_DEVICE_TYPE_CPU = 1
_FORMAT_FLOAT3 = 3
_ERROR_NONE = 0
_ERROR_CANCELLED = 6
_ERROR_NAMES = {1: "unknown error", 2: "invalid argument", 3: "invalid operation",
                4: "out of memory", 5: "unsupported hardware", 6: "cancelled"}


class DenoiserMissing(Exception):
    """OpenImageDenoise could not be loaded; the message names every place looked at."""


class DenoiseError(Exception):
    """OpenImageDenoise failed; the message is the library's own."""


class Cancelled(Exception):
    """The user cancelled while the denoiser ran."""


def library_names(platform: str = sys.platform) -> tuple[str, ...]:
    """File names of OpenImageDenoise's main library on `platform`, the versioned one first."""
    if platform == "win32":
        return ("OpenImageDenoise.dll",)
    if platform == "darwin":
        return ("libOpenImageDenoise.2.dylib", "libOpenImageDenoise.dylib")
    return ("libOpenImageDenoise.so.2", "libOpenImageDenoise.so")


def library_folders(blender_binary: str | os.PathLike | None,
                    bpy_folder: str | os.PathLike | None) -> list[Path]:
    """Folders where Blender keeps its shared libraries, beside its executable (Linux:
    `lib/`; Windows: `blender.shared/` or beside the executable; macOS: the bundle's
    `Resources/lib/`) and inside the bpy module (`bpy/lib/`, or `bpy/` itself on Windows)."""
    folders = []
    if blender_binary:
        here = Path(blender_binary).resolve().parent
        folders += [here / "lib", here / "blender.shared", here,
                    here.parent / "Resources" / "lib", here.parent / "lib"]
    if bpy_folder:
        root = Path(bpy_folder).resolve()
        folders += [root / "lib", root / "blender.shared", root]
    unique = []
    for folder in folders:
        if folder not in unique:
            unique.append(folder)
    return unique


def candidates(blender_binary=None, bpy_folder=None, environ=None,
               platform: str = sys.platform) -> list[str]:
    """What to try loading, in order: $PHOTON_OIDN_LIBRARY, the main library in each of
    `library_folders` (also a versioned file name such as libOpenImageDenoise.so.2.3.3, never
    the `_core` or `_device_*` modules beside it), then the bare names for the system's own
    search (a library Blender has already loaded is found so)."""
    environ = os.environ if environ is None else environ
    found = []
    if environ.get(ENV_VAR):
        found.append(str(Path(environ[ENV_VAR]).expanduser()))
    names = library_names(platform)
    stem = names[0].split(".")[0]  # libOpenImageDenoise / OpenImageDenoise
    for folder in library_folders(blender_binary, bpy_folder):
        for name in names:
            if (folder / name).is_file():
                found.append(str(folder / name))
        if folder.is_dir():
            for path in sorted(folder.glob(f"{stem}.*")):
                if path.is_file() and str(path) not in found:
                    found.append(str(path))
    found += list(names)
    system = ctypes.util.find_library("OpenImageDenoise")
    if system:
        found.append(system)
    return found


def load_library(paths: list[str]) -> ctypes.CDLL:
    """The first of `paths` that loads and has OpenImageDenoise 2's API, with its function
    signatures declared; DenoiserMissing (naming what was tried) if none does."""
    tried = []
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
        except OSError as exc:
            tried.append(f"{path} ({exc})" if os.path.isabs(path) else path)
            continue
        if not hasattr(lib, "oidnSetSharedFilterImage") or not hasattr(lib, "oidnSetFilterBool"):
            tried.append(f"{path} (not OpenImageDenoise 2)")
            continue
        _declare(lib)
        return lib
    raise DenoiserMissing("OpenImageDenoise was not found; tried: " + "; ".join(tried)
                          + f". Set {ENV_VAR} to the library's path.")


_LIBRARY = None


def library(blender_binary=None, bpy_folder=None) -> ctypes.CDLL:
    """The OpenImageDenoise library, loaded once per process (see `candidates`)."""
    global _LIBRARY
    if _LIBRARY is None:
        _LIBRARY = load_library(candidates(blender_binary, bpy_folder))
    return _LIBRARY


PROGRESS_MONITOR = ctypes.CFUNCTYPE(ctypes.c_bool, ctypes.c_void_p, ctypes.c_double)


def _declare(lib):
    p, s, i, b = ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int, ctypes.c_bool
    size = ctypes.c_size_t
    for name, args, result in (
            ("oidnNewDevice", [i], p), ("oidnCommitDevice", [p], None),
            ("oidnSetDeviceInt", [p, s, i], None), ("oidnReleaseDevice", [p], None),
            ("oidnGetDeviceError", [p, ctypes.POINTER(s)], i),
            ("oidnNewFilter", [p, s], p), ("oidnCommitFilter", [p], None),
            ("oidnSetSharedFilterImage", [p, s, p, i, size, size, size, size, size], None),
            ("oidnSetFilterBool", [p, s, b], None), ("oidnExecuteFilter", [p], None),
            ("oidnSetFilterProgressMonitorFunction", [p, PROGRESS_MONITOR, p], None),
            ("oidnReleaseFilter", [p], None)):
        function = getattr(lib, name)
        function.argtypes = args
        function.restype = result


class _Device:
    """One CPU device for one denoise, its errors checked after every step."""

    def __init__(self, lib, threads: int, should_cancel):
        self.lib = lib
        self.handle = lib.oidnNewDevice(_DEVICE_TYPE_CPU)
        if not self.handle:
            raise DenoiseError("OpenImageDenoise could not create a CPU device")
        self.filters = []
        self._keep = []  # buffers and callbacks the library points to until release
        self._should_cancel = should_cancel
        if threads > 0:
            lib.oidnSetDeviceInt(self.handle, b"numThreads", threads)
        lib.oidnCommitDevice(self.handle)
        self.check("creating the device")

    def check(self, what: str):
        message = ctypes.c_char_p()
        code = self.lib.oidnGetDeviceError(self.handle, ctypes.byref(message))
        if code == _ERROR_CANCELLED:
            raise Cancelled()
        if code != _ERROR_NONE:
            text = (message.value or b"").decode("utf-8", errors="replace")
            raise DenoiseError(f"OpenImageDenoise failed {what}: "
                               f"{text or _ERROR_NAMES.get(code, f'error {code}')}")

    def run_filter(self, images: dict, *, clean_aux: bool, what: str):
        """Run one "RT" filter on `images` (name -> contiguous float32 array of 3 or 4
        channels per pixel, row after row; only the first three are read or written)."""
        lib = self.lib
        flt = lib.oidnNewFilter(self.handle, b"RT")
        self.check(f"creating the filter for {what}")
        self.filters.append(flt)
        for name, array in images.items():
            height, width, channels = array.shape
            self._keep.append(array)
            lib.oidnSetSharedFilterImage(flt, name.encode(), array.ctypes.data, _FORMAT_FLOAT3,
                                         width, height, 0, 4 * channels, 4 * channels * width)
        lib.oidnSetFilterBool(flt, b"hdr", "color" in images)
        lib.oidnSetFilterBool(flt, b"cleanAux", clean_aux)
        if self._should_cancel is not None:
            monitor = PROGRESS_MONITOR(lambda _user, _progress: not self._should_cancel())
            self._keep.append(monitor)
            lib.oidnSetFilterProgressMonitorFunction(flt, monitor, None)
        lib.oidnCommitFilter(flt)
        self.check(f"setting up {what}")
        lib.oidnExecuteFilter(flt)
        self.check(f"denoising {what}")

    def release(self):
        for flt in self.filters:
            self.lib.oidnReleaseFilter(flt)
        self.lib.oidnReleaseDevice(self.handle)
        self._keep.clear()


def denoise(lib, color: np.ndarray, albedo: np.ndarray, normal: np.ndarray, *,
            prefilter: str = "ACCURATE", threads: int = 0, should_cancel=None) -> np.ndarray:
    """The denoised image of `color` (H x W x 3 or 4, linear HDR; a fourth channel, alpha, is
    copied) guided by `albedo` and `normal` (H x W x 3 or more), prefiltered as `prefilter`
    says (one of PREFILTERS)."""
    if prefilter not in PREFILTERS:
        raise ValueError(f"unknown prefilter {prefilter!r}")
    color = np.ascontiguousarray(color, dtype=np.float32)
    albedo = np.ascontiguousarray(albedo, dtype=np.float32)
    normal = np.ascontiguousarray(normal, dtype=np.float32)
    if not (color.shape[:2] == albedo.shape[:2] == normal.shape[:2]):
        raise ValueError("the colour and the guides differ in size")
    output = color.copy()
    device = _Device(lib, threads, should_cancel)
    try:
        if prefilter == "ACCURATE":
            clean_albedo, clean_normal = albedo.copy(), normal.copy()
            device.run_filter({"albedo": albedo, "output": clean_albedo}, clean_aux=False,
                              what="the albedo")
            device.run_filter({"normal": normal, "output": clean_normal}, clean_aux=False,
                              what="the normal")
            albedo, normal = clean_albedo, clean_normal
        device.run_filter({"color": color, "albedo": albedo, "normal": normal,
                           "output": output}, clean_aux=prefilter != "FAST", what="the image")
    finally:
        device.release()
    return output


def _read_pass(layer, name: str, width: int, height: int, channels: int) -> np.ndarray:
    values = np.empty(width * height * channels, dtype=np.float32)
    layer.passes[name].rect.foreach_get(values)
    return values.reshape(height, width, channels)


def denoise_layer(lib, layer, width: int, height: int, *, prefilter: str = "ACCURATE",
                  threads: int = 0, should_cancel=None):
    """Denoise a render layer (Blender's `RenderLayer` of a result being filled): its
    Combined is copied to "Noisy Image" and replaced by the denoised image, guided by its
    Denoising Albedo and Denoising Normal passes. With `lib` None (no library), only the copy."""
    noisy = _read_pass(layer, "Combined", width, height, 4)
    layer.passes["Noisy Image"].rect.foreach_set(noisy.ravel())
    if lib is None:
        return
    albedo = _read_pass(layer, "Denoising Albedo", width, height, 3)
    normal = _read_pass(layer, "Denoising Normal", width, height, 3)
    clean = denoise(lib, noisy, albedo, normal, prefilter=prefilter, threads=threads,
                    should_cancel=should_cancel)
    layer.passes["Combined"].rect.foreach_set(clean.ravel())
