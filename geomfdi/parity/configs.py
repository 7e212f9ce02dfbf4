"""Redundant single-axis sensor configurations (measurement matrices ``H``).

Each function returns the ``m x 3`` matrix whose rows are the unit sensing axes of ``m``
single-axis sensors (gyros or accelerometers) measuring a 3-vector, so that the
measurement model is ``Z = H x + eps`` .  They are re-exported by
:mod:`geomfdi.parity.fdi` (``gf.parity.dodecahedron()``).

References
----------
Qin Yongyuan, Niu Huifang, "Soft fault detection and isolation to ensure the entire
attitude measuring of a strapdown inertial navigation system", Journal of Astronautics,
1999, §4: six gyros along the normals of a regular dodecahedron.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._validation import (
    as_index,
    as_int,
    as_matrix,
    as_positive,
    as_real_array,
    as_vector,
)
from geomfdi.errors import GeomFDIError

__all__ = [
    "dodecahedron",
    "cone",
    "tetrahedron",
    "MAGIC_HALF_ANGLE",
    "axis_cosines",
    "from_direction_cosines",
    "from_angles",
    "scale_factor_fault",
    "misalignment_fault",
]

MAGIC_HALF_ANGLE = float(np.arccos(1.0 / np.sqrt(3.0)))
"""Cone half-angle ``arccos(1/sqrt 3)`` (54.7356 deg) for which ``H^T H = (m/3) I``."""


def dodecahedron() -> np.ndarray:
    """Six sensing axes along the face normals of a regular dodecahedron.

    Returns
    -------
    H : ndarray, shape (6, 3)
        Unit rows ``(a, 0, b), (-a, 0, b), (b, a, 0), (b, -a, 0), (0, b, a), (0, b, -a)``
        with ``a = sin(alpha)``, ``b = cos(alpha)`` and ``2 alpha = arccos(1/sqrt 5)``
        (63.43 deg, the angle between any two axes).

    Notes
    -----
    Every pair of axes satisfies ``|cos| = 1/sqrt 5``, ``H^T H = 2 I`` and the parity
    projector ``W = I - H (H^T H)^{-1} H^T`` has ``w_ii = 1/2`` .  The sensor
    numbering is the one of Qin & Niu (1999) (its reference [8], p. 92): with this ordering the
    gyro pairs that Qin & Niu (1999)'s Table 1 reports for the noise-free single-fault
    statistics ``D+_ij`` and ``D-_ij`` are maximisers of those statistics (the
    configuration is so symmetric that the maximisers are ties; the test suite checks
    that all twelve reported pairs are among them).

    References
    ----------
    Qin & Niu (1999), §4 and Table 1.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> H = gf.parity.dodecahedron()
    >>> np.allclose(H.T @ H, 2 * np.eye(3))
    True
    """
    cos2a = 1.0 / np.sqrt(5.0)
    a = np.sqrt((1.0 - cos2a) / 2.0)
    b = np.sqrt((1.0 + cos2a) / 2.0)
    return np.array(
        [
            [a, 0.0, b],
            [-a, 0.0, b],
            [b, a, 0.0],
            [b, -a, 0.0],
            [0.0, b, a],
            [0.0, b, -a],
        ]
    )


def cone(m: int, half_angle: float = MAGIC_HALF_ANGLE, *, degrees: bool = False) -> np.ndarray:
    """``m`` sensing axes equally spaced in azimuth on a cone around the z axis.

    Parameters
    ----------
    m : int
        Number of sensors, ``m >= 3``.
    half_angle : float
        Angle between each axis and the cone axis z, in ``(0, pi/2)`` (radians unless
        ``degrees``).  Default ``arccos(1/sqrt 3)`` (54.74 deg), for which
        ``H^T H = (m/3) I``: every direction is measured equally well.
    degrees : bool
        Read ``half_angle`` in degrees.

    Returns
    -------
    H : ndarray, shape (m, 3)
        Rows ``(sin t cos phi_k, sin t sin phi_k, cos t)``, ``phi_k = 2 pi k / m``.

    Notes
    -----
    A cone of ``m = 5`` or ``m = 6`` sensors is the classic skewed gyro or accelerometer
    array.  ``m = 3`` has no redundancy (a :class:`~geomfdi.parity.ParityFDI` on it
    raises); ``m = 4`` detects a single fault but cannot isolate it.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> H = gf.parity.cone(5)
    >>> np.allclose(H.T @ H, 5 / 3 * np.eye(3))
    True
    """
    m = as_int(m, "m", minimum=3)
    t = as_positive(half_angle, "half_angle")
    if degrees:
        t = np.deg2rad(t)
    if not t < np.pi / 2:
        raise GeomFDIError(
            f"half_angle: must lie in (0, pi/2) rad (0 to 90 deg), got {half_angle}",
            argument="half_angle",
        )
    phi = 2.0 * np.pi * np.arange(m) / m
    return np.column_stack(
        [np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi), np.full(m, np.cos(t))]
    )


def tetrahedron() -> np.ndarray:
    """Four sensing axes along the face normals of a regular tetrahedron.

    Returns
    -------
    H : ndarray, shape (4, 3)
        Rows ``(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)`` divided by ``sqrt 3``;
        ``H^T H = (4/3) I``, pairwise ``|cos| = 1/3``.

    Notes
    -----
    With ``m - n = 1`` parity equation the configuration detects a single fault but
    cannot isolate it: every column of ``V`` is parallel to every other.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> np.allclose(gf.parity.tetrahedron().T @ gf.parity.tetrahedron(), 4 / 3 * np.eye(3))
    True
    """
    return np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float) / np.sqrt(3.0)


def axis_cosines(H: np.ndarray) -> np.ndarray:
    """Cosines of the angles between the sensing axes (rows of ``H``), shape (m, m).

    Zero rows (sensors that measure nothing) get cosine 0 with every other axis.
    """
    H = np.asarray(H, dtype=float)
    norms = np.linalg.norm(H, axis=1)
    safe = np.where(norms > 0, norms, 1.0)
    U = H / safe[:, None]
    C = U @ U.T
    C[norms == 0, :] = 0.0
    C[:, norms == 0] = 0.0
    return np.clip(C, -1.0, 1.0)


def from_direction_cosines(cosines: Any) -> np.ndarray:
    """Measurement matrix from the direction cosines of the sensing axes.

    Parameters
    ----------
    cosines : array_like, shape (m, 3)
        One row per sensor: the cosines of its axis with the body x, y, z axes (any
        non-zero length; rows are normalised to unit length).

    Returns
    -------
    H : ndarray, shape (m, 3)
        Unit rows.

    Examples
    --------
    >>> from_direction_cosines([[1, 0, 0], [0, 2, 0], [0, 0, 1], [1, 1, 1]]).round(4)[3]
    array([0.5774, 0.5774, 0.5774])
    """
    H = as_matrix(cosines, "cosines", cols=3)
    norms = np.linalg.norm(H, axis=1)
    if np.any(norms == 0):
        raise GeomFDIError(
            f"cosines: row {int(np.argmin(norms))} is zero (no sensing axis)", argument="cosines"
        )
    return H / norms[:, None]


def from_angles(azimuth: Any, elevation: Any, *, degrees: bool = False) -> np.ndarray:
    """Measurement matrix from azimuth and elevation angles of the sensing axes.

    Row ``i`` is ``(cos e_i cos a_i, cos e_i sin a_i, sin e_i)``: azimuth ``a`` in the
    x-y plane from x towards y, elevation ``e`` from that plane towards z.

    Examples
    --------
    >>> import numpy as np
    >>> H = from_angles([0, 120, 240, 0], [35.26439, 35.26439, 35.26439, 90], degrees=True)
    >>> np.round(H[:, 2], 4).tolist()
    [0.5774, 0.5774, 0.5774, 1.0]
    """
    az = as_vector(azimuth, "azimuth")
    el = as_vector(elevation, "elevation", length=az.size)
    if degrees:
        az, el = np.radians(az), np.radians(el)
    return np.column_stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def scale_factor_fault(H: Any, x: Any, sensor: int, k: float) -> np.ndarray:
    """Additive fault of a scale-factor error ``k`` on ``sensor``: ``k h_i^T x``.

    Parameters
    ----------
    H : array_like, (m, n)
    x : array_like, (N, n) or (n,)
        True states (the fault grows with the measured quantity).
    sensor : int
    k : float
        Relative scale-factor error (``0.01``: the sensor reads 1 % high).

    Returns
    -------
    ndarray, (N, m)
        Add it to the fault-free measurements ``x H^T``.
    """
    Hm = as_matrix(H, "H")
    i = as_index(sensor, "sensor", Hm.shape[0])
    X = np.atleast_2d(as_real_array(x, "x"))
    if X.shape[-1] != Hm.shape[1]:
        raise GeomFDIError(f"x: expected {Hm.shape[1]} columns", argument="x")
    out = np.zeros((X.shape[0], Hm.shape[0]))
    out[:, i] = float(as_real_array(k, "k")) * (X @ Hm[i])
    return out


def misalignment_fault(
    H: Any, x: Any, sensor: int, angle: float, *, about: Any = None, degrees: bool = False
) -> np.ndarray:
    """Additive fault of a misaligned axis: ``(h_i' - h_i)^T x``, ``h_i'`` rotated.

    The unit axis ``h_i`` (of a 3-axis configuration) is rotated by ``angle`` about the
    unit vector ``about`` (default: perpendicular to ``h_i`` and to the body axis it is
    least aligned with), by Rodrigues' formula.

    Returns
    -------
    ndarray, (N, m)
        Add it to the fault-free measurements ``x H^T``.
    """
    Hm = as_matrix(H, "H", cols=3)
    i = as_index(sensor, "sensor", Hm.shape[0])
    X = np.atleast_2d(as_real_array(x, "x"))
    if X.shape[-1] != 3:
        raise GeomFDIError("x: expected 3 columns", argument="x")
    th = float(as_real_array(angle, "angle"))
    th = np.radians(th) if degrees else th
    h = Hm[i]
    if about is None:
        k = np.cross(h, np.eye(3)[int(np.argmin(np.abs(h)))])
    else:
        k = as_vector(about, "about", length=3)
    nk = np.linalg.norm(k)
    if nk == 0:
        raise GeomFDIError("about: the rotation axis must be non-zero", argument="about")
    k = k / nk
    h_rot = h * np.cos(th) + np.cross(k, h) * np.sin(th) + k * (k @ h) * (1 - np.cos(th))
    out = np.zeros((X.shape[0], Hm.shape[0]))
    out[:, i] = X @ (h_rot - h)
    return out
