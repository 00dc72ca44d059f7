"""Read-only public attributes for the optimizer's objects (consumer 2 of the step residual):
an OptimalControlProblem and its Transcription are built once, and problems that differ
in their data are new objects (`with_boundary`, `with_parameters`) that may share the
NLP, so an assignment that would make a problem and its NLP disagree is refused; a
problem's attributes that are its transcription's (`Transcribed`) are read through to it.
"""


class ReadOnly:
    """A class whose public attributes cannot be assigned or deleted: AttributeError names
    the attribute and the way to change it (`_CHANGE`, by attribute name, else
    `_CHANGE_ANY`). Private attributes (a leading underscore) are set while building."""

    _CHANGE = {}
    _CHANGE_ANY = "build a new object instead"

    def __setattr__(self, name, value):
        if name.startswith("_"):
            object.__setattr__(self, name, value)
            return
        raise AttributeError(self._refusal(name, "assigned"))

    def __delattr__(self, name):
        if name.startswith("_"):
            object.__delattr__(self, name)
            return
        raise AttributeError(self._refusal(name, "deleted"))

    def _refusal(self, name, done):
        kind = type(self).__name__
        return (f"`{kind}.{name}` is read-only and cannot be {done}: "
                f"{self._CHANGE.get(name, self._CHANGE_ANY)}.")


def frozen(array):
    """`array` made read-only (and returned), so that a problem's data, bounds and scales
    change only through `with_boundary` and `with_parameters`."""
    array.flags.writeable = False
    return array


class Transcribed:
    """A read-only attribute of OptimalControlProblem that is its transcription's
    (``problem.x_layout is problem.transcription.x_layout``)."""

    def __set_name__(self, owner, name):
        self.name = name
        self.__doc__ = f"``problem.transcription.{name}`` (`Transcription`)."

    def __get__(self, problem, owner=None):
        return self if problem is None else getattr(problem._transcription, self.name)
