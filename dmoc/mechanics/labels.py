"""Names of a system's coordinates and controls, part of the mechanics stage: declared once
with the system (``names=("x", "y", "theta")``, ``control_names=("force", "torque")``),
checked there, and used by the results stage in plot labels and by the command line as the
CSV table's columns.
"""


def coordinate_names(names, n, problems):
    """The names of the n coordinates: `names` checked, or q0, q1, ... when None."""
    return _names("names", names, n, "q", "coordinates", problems)


def control_names(names, n_u, problems):
    """The names of the n_u controls: `names` checked, or u0, u1, ... when None."""
    return _names("control_names", names, n_u, "u", "controls", problems)


def _names(argument, names, count, prefix, what, problems):
    """`names` as a tuple of `count` distinct one-line strings without commas (the CSV
    table's unquoted column names); problems are appended to `problems`."""
    default = tuple(f"{prefix}{i}" for i in range(count))
    if names is None:
        return default
    if isinstance(names, str) or not hasattr(names, "__iter__"):
        problems.append(f"`{argument}` must be a sequence of {count} strings, one per "
                        f"{what[:-1]}; got {names!r}.")
        return default
    names = tuple(names)
    if len(names) != count or not all(isinstance(s, str) for s in names):
        problems.append(f"`{argument}` must be {count} strings, one for each of the {count} "
                        f"{what}; got {names!r}.")
        return default
    repeated = sorted({s for s in names if names.count(s) > 1})
    if repeated:
        problems.append(f"`{argument}` must be distinct (each names a column of the CSV table "
                        f"and a plot axis); got {repeated} more than once in {names!r}.")
    unsafe = [s for s in names if any(c in s for c in ",\r\n")]
    if unsafe:
        problems.append(f"`{argument}` must not contain commas or line breaks (they are the "
                        f"CSV table's column names, unquoted); got {unsafe}: write e.g. 'x_1' "
                        f"for 'x,1'.")
    return names
