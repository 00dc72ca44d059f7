"""The blocks of steps the simulator evaluates a horizon in (its chunks): each compiled call of
the stepper's `mapaccum` (`dmoc.simulation.stepper`) takes the largest power of two of the
steps left, at most CHUNK (`chunk_length`), so a stepper builds only the horizons of 1, 2,
4, ..., CHUNK steps (`chunk_sizes`); runs in lockstep (`dmoc.simulation.lockstep`) share a
call in blocks of at most LOCKSTEP runs.
"""

CHUNK = 1024      # steps per compiled call; shorter calls use powers of two, so at most
                  # log2(CHUNK) + 1 horizons are ever built per stepper
LOCKSTEP = 16     # runs per call in lockstep (`DiracStepper.horizons_of`): CasADi's map builds in
                  # ~0.1 ms up to a few dozen runs, in tens of ms for hundreds


def chunk_length(remaining):
    """Steps of the next compiled call with `remaining` steps to go: the largest power of
    two up to `remaining` and CHUNK."""
    return min(CHUNK, 1 << (remaining.bit_length() - 1))


def chunk_sizes():
    """The horizon lengths `DiracStepper.run` uses: 1, 2, 4, ..., CHUNK."""
    return [1 << i for i in range(CHUNK.bit_length())]
