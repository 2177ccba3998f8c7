"""Host entry points of the CUDA kernels: shape checks, the ``(C, F, H, W)`` <-> ``(C, F, P)``
layout, constant uploads and the batched launch (:func:`fringe3d.gpu.streaming.run_batched`).

Every function takes one cycle ``(F, H, W)`` or many ``(C, F, H, W)`` (host or device arrays)
and returns outputs with the same leading layout: ``(H, W)`` maps for one cycle, ``(C, H, W)``
for many; with ``device_output=True`` they stay on the device (numba device arrays). Callers
normally reach these through ``backend="cuda"`` of :func:`fringe3d.phase.psp.wrapped_phase`,
:func:`fringe3d.unwrap.temporal.three_frequency_decode`,
:func:`fringe3d.unwrap.geometric.geometric_unwrap`, :meth:`fringe3d.optics.rays.RayGeometry`
users and :class:`fringe3d.reconstruct.triangulate.FastThreeStep`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from fringe3d.gpu.runtime import cuda_module, is_device_array
from fringe3d.gpu.streaming import DEFAULT_CHUNK, launch_grid, run_batched
from fringe3d.utils.camera_size import check_camera_size


def _cycles(frames, name: str = "frames"):
    """``(stack (C, F, P), (H, W), single)`` from ``(F, H, W)`` or ``(C, F, H, W)`` frames."""
    if frames.ndim == 3:
        single = True
        c, f, h, w = (1,) + tuple(frames.shape)
    elif frames.ndim == 4:
        single = False
        c, f, h, w = frames.shape
    else:
        raise ValueError(f"{name} must be (F, H, W) or (C, F, H, W) (cycles of frames), got shape {frames.shape}")
    if is_device_array(frames):
        return frames.reshape(c, f, h * w), (h, w), single
    a = np.asarray(frames)
    if a.dtype.kind not in "uif":
        raise ValueError(f"{name} must hold real numbers (uint8, uint16 or float), got {a.dtype}")
    return np.ascontiguousarray(a).reshape(c, f, h * w), (h, w), single


def _maps(x, n_cyc: int, hw: tuple[int, int], single: bool, device_output: bool, trailing: tuple = ()):
    """A (C, P, ...) output back to ``(H, W, ...)`` (one cycle) or ``(C, H, W, ...)``."""
    shape = ((n_cyc,) if not single else ()) + hw + trailing
    return x.reshape(shape)


def _check_index(idx: np.ndarray, n_frames: int) -> np.ndarray:
    idx = np.ascontiguousarray(idx, np.int64)
    if idx.size and (idx.min() < 0 or idx.max() >= n_frames):
        raise ValueError(f"frame index {idx.tolist()} out of range for {n_frames} frames")
    return idx


def wrapped_phase(frames, coef: np.ndarray, index: np.ndarray, saturation_level: float = np.inf,
                  chunk: int = DEFAULT_CHUNK, device_output: bool = False):
    """N-step least-squares wrapped phase (Eq. 2.4) on the device.

    frames (F, H, W) or (C, F, H, W); coef (3, N) float64 from
    :func:`fringe3d.phase.psp.lsq_coefficients`; index (N,) frame indices. Returns
    ``(phase, average, modulation, saturated)``, each (H, W) or (C, H, W): float32 rad in
    (-pi, pi], float32, float32, bool.
    """
    cuda = cuda_module()
    stack, hw, single = _cycles(frames)
    idx = cuda.to_device(_check_index(index, stack.shape[1]))
    d_coef = cuda.to_device(np.ascontiguousarray(coef, np.float64))
    sat = float(saturation_level)
    from fringe3d.gpu.phase_kernels import psp_kernel

    def launch(src, outs, stream):
        blocks, threads = launch_grid(src.shape[2], src.shape[0])
        psp_kernel[blocks, threads, stream](src, idx, d_coef, sat, *outs)

    p = hw[0] * hw[1]
    res = run_batched(cuda, stack, launch, [((p,), np.float32)] * 3 + [((p,), np.bool_)], chunk, device_output)
    return tuple(_maps(r, stack.shape[0], hw, single, device_output) for r in res)


def three_frequency(frames, idx: list, coef: list, params: np.ndarray, chunk: int = DEFAULT_CHUNK,
                    device_output: bool = False):
    """Fused three-frequency decode on the device (the CPU kernel's arguments: three index
    arrays, three float32 (3, N_g) coefficient matrices, the float32 ``params``). Returns
    ``(phase, wrapped, modulation, average, mask, texture)``, each (H, W) or (C, H, W)."""
    cuda = cuda_module()
    stack, hw, single = _cycles(frames)
    d_idx = [cuda.to_device(_check_index(i, stack.shape[1])) for i in idx]
    d_coef = [cuda.to_device(np.ascontiguousarray(c, np.float32)) for c in coef]
    d_params = cuda.to_device(np.ascontiguousarray(params, np.float32))
    from fringe3d.gpu.unwrap_kernels import three_frequency_kernel

    def launch(src, outs, stream):
        blocks, threads = launch_grid(src.shape[2], src.shape[0])
        three_frequency_kernel[blocks, threads, stream](src, d_idx[0], d_coef[0], d_idx[1], d_coef[1], d_idx[2],
                                                        d_coef[2], d_params, *outs)

    p = hw[0] * hw[1]
    specs = [((p,), np.float32)] * 4 + [((p,), np.bool_), ((p,), np.float32)]
    res = run_batched(cuda, stack, launch, specs, chunk, device_output)
    return tuple(_maps(r, stack.shape[0], hw, single, device_output) for r in res)


def _per_cycle_maps(cuda, a, name: str, dtype):
    """(C, P) device array and ((H, W), single) from an (H, W) or (C, H, W) host/device map."""
    if a.ndim not in (2, 3):
        raise ValueError(f"{name} must be (H, W) or (C, H, W), got shape {a.shape}")
    single = a.ndim == 2
    c, h, w = ((1,) + tuple(a.shape)) if single else tuple(a.shape)
    if is_device_array(a):
        return a.reshape(c, h * w), (h, w), single
    return cuda.to_device(np.ascontiguousarray(a, dtype).reshape(c, h * w)), (h, w), single


def geometric_unwrap(wrapped, phi_min: np.ndarray, sign: np.ndarray, mask=None, device_output: bool = False):
    """Geometric-constraint unwrapping (Eq. 4.20-4.21) on the device: wrapped (H, W) or
    (C, H, W) float32 rad; phi_min (H, W) float32 and sign (H, W) int8 of a
    :class:`fringe3d.unwrap.geometric.MinimumPhase`; mask like ``wrapped`` (bool) or None.
    Returns ``(phase, valid)``: float32 rad (NaN invalid) and bool, shaped like ``wrapped``."""
    cuda = cuda_module()
    d_w, hw, single = _per_cycle_maps(cuda, wrapped, "wrapped phase", np.float32)
    if tuple(np.shape(phi_min)) != hw:
        raise ValueError(f"wrapped phase is {hw} but the minimum phase map is {np.shape(phi_min)}")
    n_cyc, p = d_w.shape
    d_m = (_per_cycle_maps(cuda, mask, "mask", np.bool_)[0] if mask is not None
           else cuda.to_device(np.ones((1, 1), bool)))
    if mask is not None and tuple(d_m.shape) != (n_cyc, p):
        raise ValueError(f"mask {tuple(mask.shape)} must match the wrapped phase {tuple(wrapped.shape)}")
    d_pm = cuda.to_device(np.ascontiguousarray(phi_min, np.float32).ravel())
    d_sg = cuda.to_device(np.ascontiguousarray(sign, np.int8).ravel())
    phase = cuda.device_array((n_cyc, p), np.float32)
    valid = cuda.device_array((n_cyc, p), np.bool_)
    from fringe3d.gpu.unwrap_kernels import geometric_kernel

    blocks, threads = launch_grid(p, n_cyc)
    geometric_kernel[blocks, threads](d_w, d_pm, d_sg, d_m, mask is not None, phase, valid)
    cuda.synchronize()
    res = (phase, valid) if device_output else (phase.copy_to_host(), valid.copy_to_host())
    return tuple(_maps(r, n_cyc, hw, single, device_output) for r in res)


def _ray_constants(cuda, O, D_planes, Q, P3):
    h, w = D_planes.shape[1:]
    return (cuda.to_device(np.ascontiguousarray(O, np.float64)),
            cuda.to_device(np.ascontiguousarray(D_planes, np.float32).reshape(3, h * w)),
            cuda.to_device(np.ascontiguousarray(Q, np.float64)), cuda.to_device(np.ascontiguousarray(P3, np.float64)))


def central_points(w, mask, O, D_planes, Q, P3, device_output: bool = False):
    """Closed-form points along pinhole camera rays (Eq. 2.37) on the device: w (H, W) or
    (C, H, W) projector coordinate (px), mask like it (bool) or None; the ray coefficients of
    a central :class:`fringe3d.optics.rays.RayGeometry` (``O`` (3,), ``D_planes`` (3, H, W),
    ``Q``, ``P3`` (4,)). Returns (H, W, 3) or (C, H, W, 3) float32 mm, NaN invalid."""
    cuda = cuda_module()
    d_w, hw, single = _per_cycle_maps(cuda, w, "projector coordinate map", np.float64)
    if tuple(D_planes.shape[1:]) != hw:
        raise ValueError(f"projector coordinate map is {hw} but the camera is {tuple(D_planes.shape[1:])}")
    n_cyc, p = d_w.shape
    if mask is None:
        d_m = cuda.to_device(np.ones((n_cyc, p), bool))
    else:
        d_m = _per_cycle_maps(cuda, mask, "mask", np.bool_)[0]
        if tuple(d_m.shape) != (n_cyc, p):
            raise ValueError(f"mask {tuple(mask.shape)} must match the projector coordinate map {tuple(w.shape)}")
    out = cuda.device_array((n_cyc, p, 3), np.float32)
    from fringe3d.gpu.triangulate_kernels import central_points_kernel

    blocks, threads = launch_grid(p, n_cyc)
    central_points_kernel[blocks, threads](d_w, d_m, *_ray_constants(cuda, O, D_planes, Q, P3), out)
    cuda.synchronize()
    res = out if device_output else out.copy_to_host()
    return _maps(res, n_cyc, hw, single, device_output, (3,))


class ThreeStepGeometry(NamedTuple):
    """The per-rig host arrays of the fused 3-step kernel
    (:func:`fringe3d.reconstruct._kernels.three_step_kernel`), in its argument order.

    Attributes
    ----------
    coef : (3, 3) float64
        Least-squares phase coefficients of the three shifts
        (:func:`fringe3d.phase.psp.lsq_coefficients`), dimensionless.
    phi_min : (H, W) float32
        Minimum phase map ``Φ_min`` (rad, Eq. 4.19).
    sign : (H, W) int8
        Direction of the phase along depth, +1 or -1 per pixel.
    scale : float
        Projector pixels per radian of phase, ``period / 2π`` (px/rad).
    O : (3,) float64
        Camera centre, mm.
    D_planes : (3, H, W) float32
        Each pixel's ray direction with depth 1 (so the ray parameter ``s`` is the camera-frame
        depth, mm; :attr:`fringe3d.optics.rays.RayGeometry.D_planes`).
    Q, P3 : (4,) float64
        The projector's row ``cos(alpha)*P[1] + sin(alpha)*P[0]`` and third row of its (3, 4)
        projection matrix (Eq. 2.37; :class:`fringe3d.optics.rays.RayGeometry`).
    """

    coef: np.ndarray
    phi_min: np.ndarray
    sign: np.ndarray
    scale: float
    O: np.ndarray
    D_planes: np.ndarray
    Q: np.ndarray
    P3: np.ndarray


def three_step_constants(geometry: ThreeStepGeometry) -> tuple:
    """The per-rig inputs of :func:`three_step_points` uploaded once (``constants=``): a
    sequence reuses them instead of sending the ray planes (12 bytes a pixel) every call."""
    g = geometry
    cuda = cuda_module()
    return ((g.D_planes.shape[1], g.D_planes.shape[2]), cuda.to_device(np.ascontiguousarray(g.coef, np.float64)),
            cuda.to_device(np.ascontiguousarray(g.phi_min, np.float32).ravel()),
            cuda.to_device(np.ascontiguousarray(g.sign, np.int8).ravel())) + _ray_constants(cuda, g.O, g.D_planes,
                                                                                             g.Q, g.P3)


def three_step_points(frames, index, geometry: ThreeStepGeometry, min_mod2: float, chunk: int = DEFAULT_CHUNK,
                      device_output: bool = False, constants: tuple | None = None, depth: bool = False):
    """The fused 3-step + geometric + triangulation kernel on the device (the arguments of
    :func:`fringe3d.reconstruct._kernels.three_step_kernel`: the per-rig arrays ``geometry`` and
    the squared modulation threshold ``min_mod2``, frames' units squared); frames (F, H, W) or
    (C, F, H, W). ``constants`` from :func:`three_step_constants` (else uploaded now).
    Returns (H, W, 3) or (C, H, W, 3) float32 mm, NaN invalid; with ``depth`` only the ray
    parameters ``s`` of ``X = O + s*D``, (H, W) or (C, H, W) float32 mm."""
    cuda = cuda_module()
    stack, hw, single = _cycles(frames)
    check_camera_size(hw, geometry.D_planes.shape[1:], what="the frames")
    d_idx = cuda.to_device(_check_index(index, stack.shape[1]))
    if constants is None:
        constants = three_step_constants(geometry)
    _, d_coef, d_pm, d_sg = constants[:4]
    rays = constants[4:]
    mm2 = float(min_mod2)
    sc = float(geometry.scale)
    from fringe3d.gpu.triangulate_kernels import three_step_depth_kernel, three_step_kernel

    kernel = three_step_depth_kernel if depth else three_step_kernel

    def launch(src, outs, stream):
        blocks, threads = launch_grid(src.shape[2], src.shape[0])
        kernel[blocks, threads, stream](src, d_idx, d_coef, mm2, d_pm, d_sg, sc, *rays, outs[0])

    p = hw[0] * hw[1]
    tail = () if depth else (3,)
    res = run_batched(cuda, stack, launch, [((p,) + tail, np.float32)], chunk, device_output)[0]
    return _maps(res, stack.shape[0], hw, single, device_output, tail)
