"""Values computed on first access: a dataclass field that may be given as a `Pending`
computation, made and kept when it is first read, so that a result pays for a field no
caller reads (the raw re-solve's Trajectory, docs/stages/optimize.md) only when one does.
"""

import dataclasses


class Pending:
    """``make(*args)``, not made yet: the value of a `DeferredField` until first read.

    >>> Pending(sum, [1.0, 2.0])()
    3.0
    """

    __slots__ = ("make", "args")

    def __init__(self, make, *args):
        self.make, self.args = make, args

    def __call__(self):
        return self.make(*self.args)

    def __repr__(self):
        return f"Pending({getattr(self.make, '__name__', self.make)})"


class DeferredField:
    """A dataclass field whose value may be given as a `Pending`: the first read makes it
    and keeps it in its place (the instance's ``__dict__``), so every later read,
    ``vars()``, equality and ``repr`` see the value itself; anything else is kept as given.
    Required unless a `default` is given.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass
    ... class Box:
    ...     value: float = DeferredField()
    >>> box = Box(Pending(float, "2.5"))
    >>> box.value, vars(box)
    (2.5, {'value': 2.5})
    """

    def __init__(self, *default):
        self._default = default         # () or (the default,)

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, instance, owner=None):
        if instance is None:        # no class-level default: dataclass makes the field required
            if self._default:
                return self._default[0]
            raise AttributeError(self.name)
        value = instance.__dict__[self.name]
        if isinstance(value, Pending):
            value = instance.__dict__[self.name] = value()
        return value

    def __set__(self, instance, value):
        instance.__dict__[self.name] = value


def made(instance):
    """The instance's ``__dict__`` with every `Pending` value made (kept in place too): the
    state to pickle or copy, which holds no computation."""
    return {name: getattr(instance, name) for name in list(vars(instance))}


def replace(instance, **changes):
    """``dataclasses.replace(instance, **changes)`` with every field not made yet passed on
    as its `Pending`, not made (`dataclasses.replace` reads every field it is not given).

    >>> from dataclasses import dataclass
    >>> @dataclass
    ... class Box:
    ...     value: float = DeferredField()
    ...     label: str = "a"
    >>> moved = replace(Box(Pending(float, "2.5")), label="b")
    >>> vars(moved)["value"], moved.label
    (Pending(float), 'b')
    """
    pending = {name: value for name, value in vars(instance).items()
               if isinstance(value, Pending) and name not in changes}
    return dataclasses.replace(instance, **pending, **changes)
