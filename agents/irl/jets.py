"""Second-order forward-mode automatic differentiation for numpy code (truncated Taylor "jets").

A `Jet` carries, elementwise, the value f and its first and second derivatives f', f'' with
respect to one scalar parameter per element. The cost features of sim/costs.py that depend on
the ego's position (covering-circle gaps, crosswalk occupancy) are evaluated on jets by the very
same functions the planners use; every element of a trajectory depends only on its own arc
length s_k, so one jet pass gives d phi_k / d s_k and d^2 phi_k / d s_k^2 exactly
(agents/irl/laplace.py chains them with the linear maps from controls to arc lengths).

Supported: + - * / and unary -, sqrt, exp, tanh, abs, minimum, maximum (with numpy arrays or
scalars on either side), indexing, `.min(axis=...)`, and np.where / np.sum. Anything else raises
TypeError instead of silently dropping derivatives. Non-smooth points (min, max, abs at a tie)
take the derivative of the branch numpy's comparison picks.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.mixins import NDArrayOperatorsMixin


class Jet(NDArrayOperatorsMixin):
    """Elementwise (value, d/dp, d^2/dp^2) arrays of a common shape."""

    is_jet = True  # costs.py lets jets through its float conversions

    def __init__(self, value, d1=None, d2=None):
        self.value = np.asarray(value, dtype=np.float64)
        shape = self.value.shape
        self.d1 = np.zeros(shape) if d1 is None else np.broadcast_to(d1, shape).astype(float)
        self.d2 = np.zeros(shape) if d2 is None else np.broadcast_to(d2, shape).astype(float)

    @property
    def shape(self) -> tuple:
        return self.value.shape

    @property
    def ndim(self) -> int:
        return self.value.ndim

    def __getitem__(self, key) -> Jet:
        return Jet(self.value[key], self.d1[key], self.d2[key])

    def __repr__(self) -> str:
        return f"Jet(value={self.value!r}, d1={self.d1!r}, d2={self.d2!r})"

    def min(self, axis=None) -> Jet:
        """Elementwise-derivative of the minimum: the derivatives of the minimizing entry."""
        axes = tuple(range(self.ndim)) if axis is None else np.atleast_1d(axis).tolist()
        axes = [a % self.ndim for a in axes]
        rest = [a for a in range(self.ndim) if a not in axes]
        perm = rest + axes
        flat = lambda a: np.transpose(a, perm).reshape(
            [self.shape[r] for r in rest] + [-1])
        val, d1, d2 = flat(self.value), flat(self.d1), flat(self.d2)
        k = np.argmin(val, axis=-1)[..., None]
        pick = lambda a: np.take_along_axis(a, k, axis=-1)[..., 0]
        return Jet(pick(val), pick(d1), pick(d2))

    # -- numpy protocol ---------------------------------------------------------------------
    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        if method != "__call__" or kwargs:
            raise TypeError(f"Jet: {ufunc.__name__}.{method} with {sorted(kwargs)} unsupported")
        rule = _UFUNC_RULES.get(ufunc)
        if rule is None:
            raise TypeError(f"Jet: ufunc {ufunc.__name__} has no derivative rule")
        return rule(*[x if isinstance(x, Jet) else Jet(x) for x in inputs])

    def __array_function__(self, func, types, args, kwargs):
        rule = _FUNCTION_RULES.get(func)
        if rule is None:
            raise TypeError(f"Jet: numpy function {func.__name__} unsupported")
        return rule(*args, **kwargs)


def _add(a: Jet, b: Jet) -> Jet:
    return Jet(a.value + b.value, a.d1 + b.d1, a.d2 + b.d2)


def _sub(a: Jet, b: Jet) -> Jet:
    return Jet(a.value - b.value, a.d1 - b.d1, a.d2 - b.d2)


def _mul(a: Jet, b: Jet) -> Jet:
    return Jet(a.value * b.value, a.d1 * b.value + a.value * b.d1,
               a.d2 * b.value + 2.0 * a.d1 * b.d1 + a.value * b.d2)


def _reciprocal(b: Jet) -> Jet:
    r = 1.0 / b.value
    return Jet(r, -b.d1 * r * r, (2.0 * b.d1 * b.d1 * r - b.d2) * r * r)


def _div(a: Jet, b: Jet) -> Jet:
    return _mul(a, _reciprocal(b))


def _neg(a: Jet) -> Jet:
    return Jet(-a.value, -a.d1, -a.d2)


def _chain(a: Jet, f, f1, f2) -> Jet:
    """G = f(a): g' = f1 a', g'' = f1 a'' + f2 a'^2 (f1, f2: f's derivatives at a)."""
    return Jet(f, f1 * a.d1, f1 * a.d2 + f2 * a.d1 * a.d1)


def _sqrt(a: Jet) -> Jet:
    r = np.sqrt(a.value)
    with np.errstate(divide="ignore", invalid="ignore"):
        f1 = np.where(r > 0, 0.5 / r, 0.0)
        f2 = np.where(r > 0, -0.25 / (r * r * r), 0.0)
    return _chain(a, r, f1, f2)


def _exp(a: Jet) -> Jet:
    e = np.exp(a.value)
    return _chain(a, e, e, e)


def _tanh(a: Jet) -> Jet:
    t = np.tanh(a.value)
    f1 = 1.0 - t * t
    return _chain(a, t, f1, -2.0 * t * f1)


def _abs(a: Jet) -> Jet:
    sign = np.where(a.value >= 0.0, 1.0, -1.0)
    return Jet(np.abs(a.value), sign * a.d1, sign * a.d2)


def _select(cond, a: Jet, b: Jet) -> Jet:
    shape = np.broadcast_shapes(np.shape(cond), a.shape, b.shape)
    pick = lambda x, y: np.where(cond, np.broadcast_to(x, shape), np.broadcast_to(y, shape))
    return Jet(pick(a.value, b.value), pick(a.d1, b.d1), pick(a.d2, b.d2))


def _minimum(a: Jet, b: Jet) -> Jet:
    return _select(a.value <= b.value, a, b)


def _maximum(a: Jet, b: Jet) -> Jet:
    return _select(a.value >= b.value, a, b)


_UFUNC_RULES = {
    np.add: _add, np.subtract: _sub, np.multiply: _mul, np.true_divide: _div,
    np.negative: _neg, np.sqrt: _sqrt, np.exp: _exp, np.tanh: _tanh, np.absolute: _abs,
    np.minimum: _minimum, np.maximum: _maximum,
}


def _where(cond, a, b) -> Jet:
    a = a if isinstance(a, Jet) else Jet(a)
    b = b if isinstance(b, Jet) else Jet(b)
    return _select(np.asarray(cond), a, b)


def _sum(a, axis=None, **kwargs) -> Jet:
    if kwargs:
        raise TypeError(f"Jet: np.sum with {sorted(kwargs)} unsupported")
    a = a if isinstance(a, Jet) else Jet(a)
    return Jet(a.value.sum(axis=axis), a.d1.sum(axis=axis), a.d2.sum(axis=axis))


_FUNCTION_RULES = {np.where: _where, np.sum: _sum}
