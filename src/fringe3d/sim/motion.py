"""Rigid motion of scene objects over time (ch. 5: objects moving between frames).

A :class:`RigidMotion` moves an object's body frame: its origin follows the closed-form
ballistic path ``c(t) = c0 + v0 (t - t0) + a (t - t0)^2 / 2`` and its orientation spins at a
constant angular velocity ``ω`` (rad/s) about the body origin:
``R(t) = Rot(ω (t - t0)) @ R0`` (Rodrigues). With ``a = g`` this is a free-falling ball
(air drag neglected). Units: mm, s, rad.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

GRAVITY_MM_S2 = 9806.65  # standard gravity in mm/s^2


def rotation_vector_to_matrix(w) -> np.ndarray:
    """Rodrigues: rotation vector ``w`` (3,) rad (axis × angle) to a (3, 3) rotation matrix."""
    w = np.asarray(w, float)
    theta = float(np.linalg.norm(w))
    if theta < 1e-15:
        return np.eye(3)
    k = w / theta
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * Kx + (1 - np.cos(theta)) * Kx @ Kx


def _vec3(v, name):
    v = np.asarray(v, float).ravel()
    if v.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got shape {v.shape}")
    return v


@dataclass(frozen=True, eq=False)
class RigidMotion:
    """Ballistic translation plus constant spin.

    Attributes
    ----------
    velocity : (3,) mm/s, initial velocity at ``t0``.
    acceleration : (3,) mm/s^2 (e.g. gravity ``(0, 9806.65, 0)`` for +y down in a camera frame).
    angular_velocity : (3,) rad/s, spin axis × rate, in world coordinates.
    t0 : float s, time at which the object is at its nominal pose.
    """

    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    acceleration: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    t0: float = 0.0

    def __post_init__(self) -> None:  # any array-like (3,) in, float64 (3,) arrays kept
        for name in ("velocity", "acceleration", "angular_velocity"):
            object.__setattr__(self, name, _vec3(getattr(self, name), name))

    @property
    def is_static(self) -> bool:
        return not (self.velocity.any() or self.acceleration.any() or self.angular_velocity.any())

    def offset(self, time: float) -> np.ndarray:
        """Displacement of the body origin since ``t0``: ``v0 dt + a dt²/2`` (mm)."""
        dt = float(time) - self.t0
        return self.velocity * dt + 0.5 * self.acceleration * dt * dt

    def velocity_at(self, time: float) -> np.ndarray:
        """Velocity ``v0 + a dt`` (mm/s)."""
        return self.velocity + self.acceleration * (float(time) - self.t0)

    def rotation(self, time: float) -> np.ndarray:
        """Rotation accumulated since ``t0``: ``Rot(ω dt)`` (3, 3)."""
        return rotation_vector_to_matrix(self.angular_velocity * (float(time) - self.t0))

    def to_dict(self) -> dict:
        return {"velocity": self.velocity.tolist(), "acceleration": self.acceleration.tolist(),
                "angular_velocity": self.angular_velocity.tolist(), "t0": self.t0}


STATIC = RigidMotion()


def falling(velocity=(0.0, 0.0, 0.0), spin=(0.0, 0.0, 0.0), gravity=(0.0, GRAVITY_MM_S2, 0.0),
            t0: float = 0.0) -> RigidMotion:
    """Free fall: constant gravity (default +y, i.e. image-down in a camera frame, mm/s²),
    initial ``velocity`` (mm/s) and ``spin`` (rad/s).

    Parameters
    ----------
    velocity : (3,) array_like
        Initial velocity at ``t0`` (mm/s).
    spin : (3,) array_like
        Angular velocity, axis times rate, world coordinates (rad/s).
    gravity : (3,) array_like
        Constant acceleration (mm/s²), default 9806.65 mm/s² along +y.
    t0 : float
        Time (s) at which the object is at its nominal pose.

    Returns
    -------
    RigidMotion
        The ballistic motion.
    """
    return RigidMotion(velocity=velocity, acceleration=gravity, angular_velocity=spin, t0=t0)
