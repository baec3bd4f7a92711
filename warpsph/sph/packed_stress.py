"""A symmetric stress stored by its independent entries where a kernel's scratch holds it: (xx, yy, zz,
xy) in 1D and 2D, whose out-of-plane shears are zero, and (xx, yy, zz, xy, xz, yz) in 3D.
``as_tensor`` reads a stored entry (or a full mat33) as a mat33, ``as_stored(s, like)`` writes s (a mat33,
or an entry already in that form) in the form of ``like``; both are overloaded on the types (either
precision), so a generic kernel takes either array."""

import warp as wp

vec6f = wp.types.vector(length=6, dtype=wp.float32)
vec6d = wp.types.vector(length=6, dtype=wp.float64)
_PACKED = {("float32", 2): wp.vec4f, ("float64", 2): wp.vec4d, ("float32", 3): vec6f, ("float64", 3): vec6d}


def packed_stress_type(spec):
    """The Warp vector type a stress is stored as for ``spec`` (4 entries in 1D and 2D, 6 in 3D)."""
    return _PACKED[spec.precision, spec.stored_axes]


@wp.func
def as_tensor(s: wp.mat33f):
    return s


@wp.func
def as_tensor(s: wp.mat33d):  # noqa: F811 (an overload, as below)
    return s


@wp.func
def as_tensor(s: wp.vec4f):  # noqa: F811
    zero = wp.float32(0.0)
    return wp.mat33f(s[0], s[3], zero, s[3], s[1], zero, zero, zero, s[2])


@wp.func
def as_tensor(s: wp.vec4d):  # noqa: F811
    zero = wp.float64(0.0)
    return wp.mat33d(s[0], s[3], zero, s[3], s[1], zero, zero, zero, s[2])


@wp.func
def as_tensor(s: vec6f):  # noqa: F811
    return wp.mat33f(s[0], s[3], s[4], s[3], s[1], s[5], s[4], s[5], s[2])


@wp.func
def as_tensor(s: vec6d):  # noqa: F811
    return wp.mat33d(s[0], s[3], s[4], s[3], s[1], s[5], s[4], s[5], s[2])


@wp.func
def as_stored(s: wp.mat33f, like: wp.mat33f):
    return s


@wp.func
def as_stored(s: wp.mat33d, like: wp.mat33d):  # noqa: F811
    return s


@wp.func
def as_stored(s: wp.mat33f, like: wp.vec4f):  # noqa: F811
    return wp.vec4f(s[0, 0], s[1, 1], s[2, 2], s[0, 1])


@wp.func
def as_stored(s: wp.mat33d, like: wp.vec4d):  # noqa: F811
    return wp.vec4d(s[0, 0], s[1, 1], s[2, 2], s[0, 1])


@wp.func
def as_stored(s: wp.mat33f, like: vec6f):  # noqa: F811
    return vec6f(s[0, 0], s[1, 1], s[2, 2], s[0, 1], s[0, 2], s[1, 2])


@wp.func
def as_stored(s: wp.mat33d, like: vec6d):  # noqa: F811
    return vec6d(s[0, 0], s[1, 1], s[2, 2], s[0, 1], s[0, 2], s[1, 2])


@wp.func
def as_stored(s: wp.vec4f, like: wp.vec4f):  # noqa: F811
    return s


@wp.func
def as_stored(s: wp.vec4d, like: wp.vec4d):  # noqa: F811
    return s


@wp.func
def as_stored(s: vec6f, like: vec6f):  # noqa: F811
    return s


@wp.func
def as_stored(s: vec6d, like: vec6d):  # noqa: F811
    return s
