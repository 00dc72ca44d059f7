"""Units of a system's time, coordinates and controls, part of the mechanics stage: declared
once with the system (``units={"t": "s", "q": ("m", "m", "rad"), "u": ("N", "N m")}``),
checked there, and shown by the results stage in axis labels and the animation's clock.
"""

KEYS = ("t", "q", "u")


def system_units(units, n, n_u, problems):
    """The units of a system as a dict {"t": str, "q": tuple of n str, "u": tuple of n_u str}.

    Parameters
    ----------
    units : mapping or None
        Any of the keys "t" (a str), "q" (n strings, one per coordinate) and "u" (n_u
        strings, one per control); a missing key, or None, means no unit ("" for each).
    n, n_u : int
        Numbers of coordinates and of controls.
    problems : list of str
        Messages are appended here (the system reports every problem at once).

    Returns
    -------
    dict
        Every key present, "" where no unit was declared.
    """
    declared = {"t": "", "q": ("",) * n, "u": ("",) * n_u}
    if units is None:
        return declared
    if not hasattr(units, "keys"):
        problems.append(f"`units` must be a mapping with keys among {list(KEYS)} (e.g. "
                        f"{{'t': 's', 'q': ('m', 'rad')}}); got {type(units).__name__}.")
        return declared
    unknown = sorted(set(units) - set(KEYS), key=repr)
    if unknown:
        problems.append(f"`units` has unknown keys {unknown}; known keys are {list(KEYS)} "
                        f"(time, coordinates, controls).")
    if "t" in units:
        if isinstance(units["t"], str) and _printable(units["t"]):
            declared["t"] = units["t"]
        else:
            problems.append(f"`units['t']` must be one line of text (the unit of time); got "
                            f"{units['t']!r}.")
    for key, count, what in (("q", n, "coordinates"), ("u", n_u, "controls")):
        if key in units:
            declared[key] = _unit_list(f"units['{key}']", units[key], count, what, problems)
    return declared


def _unit_list(name, value, count, what, problems):
    """`value` as a tuple of `count` one-line strings, or a problem and empty units."""
    units = tuple(value) if hasattr(value, "__iter__") and not isinstance(value, str) else ()
    if len(units) != count or not all(isinstance(s, str) and _printable(s) for s in units):
        problems.append(f"`{name}` must be {count} one-line strings, one unit for each of "
                        f"the {count} {what} ('' for none); got {value!r}.")
        return ("",) * count
    return units


def _printable(text):
    return "\n" not in text and "\r" not in text
