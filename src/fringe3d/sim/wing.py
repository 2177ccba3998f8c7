"""A flapping inextensible membrane with closed-form geometry (ch. 6 ground truth).

A flat material sheet (material coordinates ``m = (x, y)`` mm: ``x`` along the span from the
root, ``y`` along the chord from the leading edge) is bent **isometrically** into a circular
cylinder of time-varying curvature ``κ(t)`` whose axis lies in the sheet along the unit material
direction ``a = (cos β, sin β)`` (``β = 0``: axis along the span, i.e. chordwise camber), then
turned rigidly about the root hinge by the flapping angle ``ψ(t)``:

    s = m·p − s0,  p = (−sin β, cos β)                         (arc length across the bend)
    B(m, t) = (m·a) a + (s0 + sin(κ s)/κ) p + (1 − cos(κ s))/κ · e_z      (body frame)
    X(m, t) = root + Rot(hinge, ψ(t)) R0 B(m, t)                  (world frame, mm)

with ``κ(t) = κ_mean + κ_amp sin(2π f t + φ_κ)`` and ``ψ(t) = ψ_amp sin(2π f t + φ_ψ)``.

Because the map is an isometry of the flat sheet and the outline is convex, the geodesic
distance between two material points is their flat distance ``|m1 − m2|`` exactly, and the image
of the flat segment is the geodesic. The second fundamental form (w.r.t. the sheet normal that
equals ``+e_z`` when flat) is ``b = κ p pᵀ`` in material coordinates: principal curvatures
``κ`` (direction ``p``) and 0 (direction ``a``). The Kirchhoff–Love bending strain of a sheet of
thickness ``h`` is ``E_αβ = (h/2) κ_αβ`` (Eq. 6.11) with ``κ_αβ = b_αβ − B_αβ`` (Eq. 6.12).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields

import numba
import numpy as np

from .hits import Hit, as_rays
from .motion import rotation_vector_to_matrix
from .scene_object import PosedObject, check_albedo, check_rotation, check_vec3

_EPS_K = 1e-12  # |κ| below this is treated as flat


def _rest_rotation() -> np.ndarray:
    """Default material → world rotation: span → +x, chord → −y (up in the image), sheet normal
    → −z (towards a camera at the origin looking along +z)."""
    return np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])


@numba.njit(cache=True)
def _wing_kernel(o, d, R, c, k, a2, p2, s0, span, chord, rect, t_out, uv_out):
    """Per ray: body-frame ray, κ-scaled ray-cylinder quadratic (plane as κ → 0), nearest root
    whose material point lies inside the outline."""
    shared = o.shape[0] == 1
    for i in range(d.shape[0]):
        j = 0 if shared else i
        t_out[i] = np.inf
        ux, uy, uz = o[j, 0] - c[0], o[j, 1] - c[1], o[j, 2] - c[2]
        ob0 = ux * R[0, 0] + uy * R[1, 0] + uz * R[2, 0]  # (X - c) @ R
        ob1 = ux * R[0, 1] + uy * R[1, 1] + uz * R[2, 1]
        ob2 = ux * R[0, 2] + uy * R[1, 2] + uz * R[2, 2]
        db0 = d[i, 0] * R[0, 0] + d[i, 1] * R[1, 0] + d[i, 2] * R[2, 0]
        db1 = d[i, 0] * R[0, 1] + d[i, 1] * R[1, 1] + d[i, 2] * R[2, 1]
        db2 = d[i, 0] * R[0, 2] + d[i, 1] * R[1, 2] + d[i, 2] * R[2, 2]
        xi = ob0 * p2[0] + ob1 * p2[1] - s0
        zeta = ob2
        dxi = db0 * p2[0] + db1 * p2[1]
        dz = db2
        A = k * (dxi * dxi + dz * dz)
        B = k * (xi * dxi + zeta * dz) - dz
        C = k * (xi * xi + zeta * zeta) - 2 * zeta
        r1, r2 = np.inf, np.inf
        if abs(k) < 1e-12:
            if B != 0.0:
                r1 = -C / (2 * B)
        else:
            disc = B * B - A * C
            if disc < 0:
                continue
            sq = np.sqrt(disc)
            q = -(B + sq) if B >= 0 else -(B - sq)
            if q == 0.0:
                continue
            r1, r2 = q / A, C / q
            if r2 < r1:
                r1, r2 = r2, r1
        for t in (r1, r2):
            if not (t > 1e-9 and t < np.inf):
                continue
            bx, by, bz = ob0 + t * db0, ob1 + t * db1, ob2 + t * db2
            bp = bx * p2[0] + by * p2[1] - s0
            sarc = bp if abs(k) < 1e-12 else np.arctan2(k * bp, 1 - k * bz) / k
            w = bx * a2[0] + by * a2[1]
            x = w * a2[0] + (sarc + s0) * p2[0]
            y = w * a2[1] + (sarc + s0) * p2[1]
            if x < 0 or x > span or y < 0:
                continue
            lim = chord if rect else chord * np.sqrt(max(0.0, 1 - (x / span) ** 4))
            if y > lim:
                continue
            t_out[i] = t
            uv_out[i, 0] = x
            uv_out[i, 1] = y
            break


@dataclass(frozen=True)
class WingShape:
    """The flat sheet's outline and its bend.

    Attributes
    ----------
    span : float
        Sheet length along the span from the root (mm); default 150 like the dissertation's wing.
    chord : float
        Sheet length along the chord from the leading edge (mm); default 70.
    outline : str
        ``"wing"``: ``0 ≤ x ≤ span``, ``0 ≤ y ≤ chord·(1 − (x/span)⁴)^½`` (convex, rounded tip);
        ``"rectangle"``: the full ``span`` × ``chord`` rectangle.
    bend_angle : float
        β, angle of the bend axis from the span direction (rad).
    bend_offset : float
        s0, position of the unbent line (mm along ``p``).
    thickness : float
        Sheet thickness h (mm), for :meth:`Wing.bending_strain`.
    """

    span: float = 150.0
    chord: float = 70.0
    outline: str = "wing"
    bend_angle: float = 0.0
    bend_offset: float = 0.0
    thickness: float = 0.1


@dataclass(frozen=True)
class WingBeat:
    """The wing's beat: ``κ(t) = kappa_mean + kappa_amp sin(2π f t + kappa_phase)`` and
    ``ψ(t) = flap_amplitude sin(2π f t + flap_phase)``.

    Attributes
    ----------
    kappa_mean : float
        Mean curvature κ_mean (1/mm).
    kappa_amp : float
        Curvature amplitude κ_amp (1/mm).
    frequency : float
        Beat frequency f (Hz), >= 0.
    flap_amplitude : float
        Flapping amplitude ψ_amp about the root hinge (rad).
    kappa_phase : float
        Phase φ_κ of the curvature (rad).
    flap_phase : float
        Phase φ_ψ of the flapping angle (rad).
    """

    kappa_mean: float = 0.0
    kappa_amp: float = 1.0 / 60
    frequency: float = 25.0
    flap_amplitude: float = float(np.radians(20))
    kappa_phase: float = 0.0
    flap_phase: float = 0.0


@dataclass(frozen=True)
class WingDots:
    """Dots painted on the membrane at material points.

    Attributes
    ----------
    anchors : sequence of (x, y) or (N, 2) array
        Material points (mm) of the dark anchor dots.
    markers : sequence of (x, y) or (N, 2) array
        Material points (mm) of the bright marker dots.
    dot_radius : float
        Radius of every dot (mm).
    anchor_albedo : float
        Albedo of the anchor dots, in [0, 1].
    marker_albedo : float
        Albedo of the marker dots, in [0, 1].
    """

    anchors: Sequence | np.ndarray = ()
    markers: Sequence | np.ndarray = ()
    dot_radius: float = 2.0
    anchor_albedo: float = 0.05
    marker_albedo: float = 0.95


_SHAPE_FIELDS = tuple(f.name for f in fields(WingShape))
_BEAT_FIELDS = tuple(f.name for f in fields(WingBeat))
_DOT_FIELDS = tuple(f.name for f in fields(WingDots))


class Wing(PosedObject):
    """Flapping, bending inextensible membrane (see the module docstring for the formulas).

    Parameters
    ----------
    shape : WingShape
        Sheet size and outline (mm), bend axis (rad) and offset (mm), thickness (mm).
    beat : WingBeat
        Curvature (1/mm) and flapping (rad) amplitudes, phases (rad) and frequency (Hz).
    root : (3,) world position of material point (0, 0) (mm), the root hinge.
    R0 : material → world rotation at rest ((3, 3) or rotation vector).
    albedo, texture : membrane albedo and optional texture (material mm coordinates).
    dots : WingDots
        Anchor and marker dots: material points (mm), radius (mm), albedos.
    """

    def __init__(self, shape: WingShape = WingShape(), beat: WingBeat = WingBeat(), root=(-75.0, 35.0, 420.0),
                 R0=None, albedo=0.6, texture=None, dots: WingDots = WingDots()):
        self.shape, self.beat = shape, beat
        span, chord, outline, thickness = shape.span, shape.chord, shape.outline, shape.thickness
        self.span, self.chord = float(span), float(chord)
        if not (self.span > 0 and self.chord > 0):
            raise ValueError(f"wing span and chord must be > 0 mm, got {span}, {chord}")
        if outline not in ("wing", "rectangle"):
            raise ValueError(f"wing outline must be 'wing' or 'rectangle', got {outline!r}")
        self.outline = outline
        self.root = check_vec3(root, "root")
        self.R0 = _rest_rotation() if R0 is None else check_rotation(R0, "R0")
        self.kappa_mean, self.kappa_amp = float(beat.kappa_mean), float(beat.kappa_amp)
        self.frequency = float(beat.frequency)
        if self.frequency < 0:
            raise ValueError(f"wing frequency must be >= 0 Hz, got {beat.frequency}")
        self.flap_amplitude = float(beat.flap_amplitude)
        self.kappa_phase, self.flap_phase = float(beat.kappa_phase), float(beat.flap_phase)
        self.beta, self.s0 = float(shape.bend_angle), float(shape.bend_offset)
        self.a2 = np.array([np.cos(self.beta), np.sin(self.beta)])
        self.p2 = np.array([-np.sin(self.beta), np.cos(self.beta)])
        self.thickness = float(thickness)
        if not self.thickness > 0:
            raise ValueError(f"wing thickness must be > 0 mm, got {thickness}")
        self.albedo = check_albedo(albedo)
        self.texture = texture
        self.anchors = np.asarray(dots.anchors, float).reshape(-1, 2)
        self.markers = np.asarray(dots.markers, float).reshape(-1, 2)
        self.dot_radius = float(dots.dot_radius)
        self.anchor_albedo = check_albedo(dots.anchor_albedo, "anchor_albedo")
        self.marker_albedo = check_albedo(dots.marker_albedo, "marker_albedo")
        for name, pts in (("anchors", self.anchors), ("markers", self.markers)):
            if len(pts) and not self.contains(pts).all():
                raise ValueError(f"wing {name} must lie inside the outline, got {pts.tolist()}")
        # the bend must not wrap the sheet round: |κ| * max|s| < π
        corners = self._outline_samples()
        s_max = np.abs(corners @ self.p2 - self.s0).max()
        k_max = abs(self.kappa_mean) + abs(self.kappa_amp)
        if k_max * s_max >= np.pi:
            raise ValueError(f"wing curvature up to {k_max:.4g}/mm over {s_max:.4g} mm would wrap the "
                             f"sheet past a half circle; expected |kappa| * extent < pi")
        self.R = self.R0
        self.center = self.root

    @classmethod
    def from_fields(cls, entry: dict) -> "Wing":
        """The wing of a scene file's flat ``wing`` entry (the inverse of :meth:`to_dict`): the
        :class:`WingShape`, :class:`WingBeat` and :class:`WingDots` fields plus ``root`` (mm),
        ``R0``, ``albedo`` and ``texture``, each optional."""
        rest = dict(entry)
        shape = WingShape(**{k: rest.pop(k) for k in _SHAPE_FIELDS if k in rest})
        beat = WingBeat(**{k: rest.pop(k) for k in _BEAT_FIELDS if k in rest})
        dots = WingDots(**{k: rest.pop(k) for k in _DOT_FIELDS if k in rest})
        return cls(shape, beat, dots=dots, **rest)

    # -- time functions ----------------------------------------------------------------------
    @property
    def moving(self) -> bool:
        return self.frequency > 0 and (self.kappa_amp != 0 or self.flap_amplitude != 0)

    def kappa(self, time: float) -> float:
        """Curvature κ(t) (1/mm), signed towards the sheet's +z side."""
        return self.kappa_mean + self.kappa_amp * np.sin(2 * np.pi * self.frequency * time + self.kappa_phase)

    def flap_angle(self, time: float) -> float:
        """Flapping angle ψ(t) (rad) about the root hinge."""
        return self.flap_amplitude * np.sin(2 * np.pi * self.frequency * time + self.flap_phase)

    def hinge_axis(self) -> np.ndarray:
        """World direction of the root hinge (the material chord axis at rest)."""
        return self.R0[:, 1]

    def pose(self, time: float = 0.0):
        """Body (flat-sheet) → world rotation and origin at ``time``."""
        Rf = rotation_vector_to_matrix(self.hinge_axis() * self.flap_angle(time))
        return Rf @ self.R0, self.root

    # -- outline -----------------------------------------------------------------------------
    def chord_at(self, x) -> np.ndarray:
        """Local chord length (mm) at span position ``x``."""
        x = np.asarray(x, float)
        if self.outline == "rectangle":
            return np.where((x >= 0) & (x <= self.span), self.chord, np.nan)
        r = np.clip(x / self.span, 0, 1)
        return self.chord * np.sqrt(1 - r**4)

    def contains(self, uv) -> np.ndarray:
        """(M,) bool: material points inside the sheet outline."""
        uv = np.asarray(uv, float).reshape(-1, 2)
        x, y = uv[:, 0], uv[:, 1]
        inside = (x >= 0) & (x <= self.span) & (y >= 0)
        with np.errstate(invalid="ignore"):
            return inside & (y <= np.nan_to_num(self.chord_at(x), nan=-1.0))

    def _outline_samples(self, n=200) -> np.ndarray:
        x = np.linspace(0, self.span, n)
        return np.concatenate([np.column_stack([x, np.zeros(n)]), np.column_stack([x, self.chord_at(x)])])

    def material_grid(self, step: float = 1.0) -> np.ndarray:
        """Material points (M, 2) on a square grid of ``step`` mm inside the outline."""
        x, y = np.meshgrid(np.arange(0, self.span + 1e-9, step), np.arange(0, self.chord + 1e-9, step))
        uv = np.column_stack([x.ravel(), y.ravel()])
        return uv[self.contains(uv)]

    # -- material <-> world ----------------------------------------------------------------
    def _bend(self, uv, k):
        """Body-frame positions (M, 3) and unit normals (M, 3) of material points for curvature k."""
        uv = np.asarray(uv, float).reshape(-1, 2)
        w = uv @ self.a2
        s = uv @ self.p2 - self.s0
        if abs(k) < _EPS_K:
            sp, sz, c, sn = s, np.zeros_like(s), np.ones_like(s), np.zeros_like(s)
        else:
            sn, c = np.sin(k * s), np.cos(k * s)
            sp, sz = sn / k, (1 - c) / k
        a3, p3, z3 = np.r_[self.a2, 0.0], np.r_[self.p2, 0.0], np.array([0.0, 0, 1])
        pos = w[:, None] * a3 + (self.s0 + sp)[:, None] * p3 + sz[:, None] * z3
        nrm = -sn[:, None] * p3 + c[:, None] * z3
        return pos, nrm

    def material_to_world(self, uv, time: float = 0.0) -> np.ndarray:
        """World positions (M, 3) mm of material points ``uv`` (M, 2) mm at ``time``."""
        R, c = self.pose(time)
        pos, _ = self._bend(uv, self.kappa(time))
        return pos @ R.T + c

    def normal(self, uv, time: float = 0.0) -> np.ndarray:
        """World unit normals (M, 3) on the sheet's +z side (the flat sheet's +e_z)."""
        R, _ = self.pose(time)
        return self._bend(uv, self.kappa(time))[1] @ R.T

    def _body_to_material(self, b, k):
        bp = b @ np.r_[self.p2, 0.0] - self.s0
        bz = b[:, 2]
        s = bp if abs(k) < _EPS_K else np.arctan2(k * bp, 1 - k * bz) / k
        w = b @ np.r_[self.a2, 0.0]
        return w[:, None] * self.a2 + (s + self.s0)[:, None] * self.p2

    def world_to_material(self, X, time: float = 0.0) -> np.ndarray:
        """Material coordinates (M, 2) mm of world points ``X`` (M, 3) on the sheet at ``time``
        (the inverse of :meth:`material_to_world`; points off the sheet are projected radially)."""
        R, c = self.pose(time)
        b = (np.asarray(X, float).reshape(-1, 3) - c) @ R
        return self._body_to_material(b, self.kappa(time))

    # -- closed-form truth -----------------------------------------------------------------
    def geodesic_distance(self, uv1, uv2) -> np.ndarray:
        """Geodesic distance (mm) on the sheet between material points: the flat distance
        ``|m1 − m2|`` (isometry + convex outline). Shapes (M, 2) → (M,)."""
        uv1, uv2 = np.asarray(uv1, float).reshape(-1, 2), np.asarray(uv2, float).reshape(-1, 2)
        if not (self.contains(uv1).all() and self.contains(uv2).all()):
            raise ValueError("geodesic_distance: material points must lie inside the wing outline")
        return np.linalg.norm(uv1 - uv2, axis=1)

    def geodesic_path(self, uv1, uv2, n: int = 100, time: float = 0.0) -> np.ndarray:
        """World polyline (n, 3) of the geodesic between two material points (image of the
        flat segment)."""
        f = np.linspace(0, 1, n)[:, None]
        uv = (1 - f) * np.asarray(uv1, float) + f * np.asarray(uv2, float)
        return self.material_to_world(uv, time)

    def curvature_tensor(self, uv, time: float = 0.0) -> np.ndarray:
        """Second fundamental form ``b_αβ`` (M, 2, 2) in material coordinates (1/mm), w.r.t. the
        +z-side normal (Eq. 6.19–6.20): ``κ(t) p pᵀ``, the same at every material point."""
        n = len(np.asarray(uv, float).reshape(-1, 2))
        return np.broadcast_to(self.kappa(time) * np.outer(self.p2, self.p2), (n, 2, 2)).copy()

    def principal_curvature(self, uv, time: float = 0.0):
        """Dominant principal curvature and its direction.

        Returns ``(k (M,), direction_material (M, 2), direction_world (M, 3))``: ``k = κ(t)``
        along material ``p``; the world direction is the unit tangent ``∂X/∂s``."""
        uv = np.asarray(uv, float).reshape(-1, 2)
        k = self.kappa(time)
        R, _ = self.pose(time)
        s = uv @ self.p2 - self.s0
        tb = np.cos(k * s)[:, None] * np.r_[self.p2, 0.0] + np.sin(k * s)[:, None] * np.array([0, 0, 1.0])
        return np.full(len(uv), k), np.tile(self.p2, (len(uv), 1)), tb @ R.T

    def curvature_tensor_xy(self, uv, time: float = 0.0) -> np.ndarray:
        """``b_αβ`` (M, 2, 2) in the dissertation's Monge parametrisation ``θ1 = X, θ2 = Y``
        (world coordinates, Eq. 6.13–6.21) with normal ``g3 = g1 × g2 / |g1 × g2|`` (``+Z``
        side): ``b_αβ = κ (g3·N) (g_α·P)(g_β·P)`` with ``g1 = (1, 0, Z_X)``, ``g2 = (0, 1, Z_Y)``,
        ``N`` the sheet normal and ``P`` the world principal direction."""
        k, _, P = self.principal_curvature(uv, time)
        N = self.normal(uv, time)
        zx, zy = -N[:, 0] / N[:, 2], -N[:, 1] / N[:, 2]
        g1 = np.column_stack([np.ones_like(zx), np.zeros_like(zx), zx])
        g2 = np.column_stack([np.zeros_like(zx), np.ones_like(zx), zy])
        sign = np.sign(N[:, 2])  # g3 · N
        p1, p2 = np.einsum("ij,ij->i", g1, P), np.einsum("ij,ij->i", g2, P)
        b = np.empty((len(k), 2, 2))
        b[:, 0, 0], b[:, 1, 1] = p1 * p1, p2 * p2
        b[:, 0, 1] = b[:, 1, 0] = p1 * p2
        return (k * sign)[:, None, None] * b

    def bending_strain(self, uv, time: float = 0.0, time_ref=None, thickness=None) -> np.ndarray:
        """Bending strain ``E_αβ = (h/2)(b_αβ(t) − B_αβ)`` (M, 2, 2), Eq. (6.11)–(6.12), in
        material coordinates; ``B`` from ``time_ref`` (default: the flat sheet, ``B = 0``)."""
        h = self.thickness if thickness is None else float(thickness)
        b = self.curvature_tensor(uv, time)
        if time_ref is not None:
            b = b - self.curvature_tensor(uv, time_ref)
        return 0.5 * h * b

    def dominant_strain(self, uv, time: float = 0.0, time_ref=None, thickness=None) -> np.ndarray:
        """Dominant (largest-magnitude) eigenvalue (M,) of :meth:`bending_strain` (Fig. 6.5)."""
        ev = np.linalg.eigvalsh(self.bending_strain(uv, time, time_ref, thickness))
        return np.where(np.abs(ev[:, 0]) > np.abs(ev[:, 1]), ev[:, 0], ev[:, 1])

    def to_dict(self) -> dict:
        d = {"type": "wing", "span": self.span, "chord": self.chord, "outline": self.outline,
             "root": self.root.tolist(), "R0": self.R0.tolist(), "kappa_mean": self.kappa_mean,
             "kappa_amp": self.kappa_amp, "frequency": self.frequency, "flap_amplitude": self.flap_amplitude,
             "kappa_phase": self.kappa_phase, "flap_phase": self.flap_phase, "bend_angle": self.beta,
             "bend_offset": self.s0, "thickness": self.thickness, "anchors": self.anchors.tolist(),
             "markers": self.markers.tolist(), "dot_radius": self.dot_radius,
             "anchor_albedo": self.anchor_albedo, "marker_albedo": self.marker_albedo}
        return {**d, **self._style_dict(motion=False)}

    def truth_fields(self, uv, time: float = 0.0) -> dict:
        """Per-point truth for the renderer (float32): ``curvature`` (M, 3) material-frame
        ``(b11, b12, b22)`` 1/mm, ``principal_curvature`` (M,) 1/mm, ``principal_direction``
        (M, 3) world unit vector, ``dominant_strain`` (M,) w.r.t. the flat sheet (Eq. 6.11)."""
        uv = np.asarray(uv, float).reshape(-1, 2)
        b = self.curvature_tensor(uv, time)
        k, _, dw = self.principal_curvature(uv, time)
        return {"curvature": np.column_stack([b[:, 0, 0], b[:, 0, 1], b[:, 1, 1]]).astype(np.float32),
                "principal_curvature": k.astype(np.float32),
                "principal_direction": dw.astype(np.float32),
                "dominant_strain": self.dominant_strain(uv, time).astype(np.float32)}

    # -- albedo ------------------------------------------------------------------------------
    def albedo_at(self, uv: np.ndarray) -> np.ndarray:
        a = super().albedo_at(uv)
        for pts, alb in ((self.anchors, self.anchor_albedo), (self.markers, self.marker_albedo)):
            for q in pts:
                a[np.hypot(uv[:, 0] - q[0], uv[:, 1] - q[1]) <= self.dot_radius] = alb
        return a

    def bounding_sphere(self, time: float = 0.0):
        """World (centre, radius) enclosing the sheet at ``time``: material samples every
        ``step`` mm (grid + outline); every sheet point is within ``step`` of a sample (the map is
        an isometry), so the radius is padded by ``step``."""
        step = max(self.span, self.chord) / 20.0
        uv = np.concatenate([self.material_grid(step), self._outline_samples(40)])
        pts = self.material_to_world(uv, time)
        c = pts.mean(axis=0)
        return c, float(np.linalg.norm(pts - c, axis=1).max()) + step

    # -- ray casting ---------------------------------------------------------------------------
    def intersect(self, origins, dirs, time: float = 0.0) -> Hit:
        """Analytic ray–cylinder intersection (plane when κ = 0), restricted to the outline."""
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        k = self.kappa(time)
        best_t = np.empty(len(d))
        best_uv = np.full((len(d), 2), np.nan)
        _wing_kernel(o, d, np.ascontiguousarray(R), c, float(k), self.a2, self.p2, self.s0, self.span,
                     self.chord, self.outline == "rectangle", best_t, best_uv)
        hit = np.isfinite(best_t)
        normal = np.full(d.shape, np.nan)
        if hit.any():
            normal[hit] = self._bend(best_uv[hit], k)[1] @ R.T
        return self._finish(best_t, normal, best_uv, d)

    def describe(self) -> str:
        return f"Wing {self.span:g}x{self.chord:g} mm, {self.frequency:g} Hz"
