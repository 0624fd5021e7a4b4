"""What the fit cells leave open: effects they neither name nor exclude, which may still change the cells
they never saw.

An effect the fit cells cannot see (a grasp effect where every fit cell is one arm, whose grasps already
hold) has a flat profile there: every value fits as well as the fitted world, so the fit rightly names none
of them, but the held-out cells may depend on it (the other arm's grasps). Each such effect is profiled on
top of the fitted world; its values that fit no worse beyond chance (χ² at 95 %, the fit's own criterion)
are the range the data allow, and an effect whose farthest allowed value changes a held-out cell's simulated
counts is left open (the simulations share their seeds, so the change is the effect's, not luck's). The
report names none of them and predicts the held-out cells with each over its whole range (its posterior: a
flat prior over the registered range, weighed by the fit cells), and with all of them mixed, each weighed
by how well it fits the fit cells on average over its range (`shares`): a prediction that carries what the
fit cells cannot say, where the fitted world alone assumes every open effect absent.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pegbt.sim.world_effects import WORLD_EFFECT_KINDS, WorldEffects
from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.fit import LR_95, Profile, candidates, profile
from pegbt.sim2real.outcomes.simulate import Mapper, simulate_cells


@dataclass(frozen=True)
class Alternative:
    """An effect the fit cells leave open: the values they allow (grid values no worse than the fitted
    world beyond chance) and the one farthest from the default (the world a campaign can run)."""

    profile: Profile
    allowed: tuple[float, ...]
    value: float

    @property
    def name(self) -> str:
        return self.profile.candidate.name

    @property
    def label(self) -> str:
        """The world that predicts with it: the fitted world and this parameter over its registered range."""
        p = WORLD_EFFECT_KINDS[self.profile.candidate.kind].parameters[self.profile.candidate.parameter]
        return f"{self.name} over {p.low:.4g}–{p.high:.4g}"

    def world(self) -> WorldEffects:
        return self.profile.candidate.world(self.value, self.profile.base)


def shares(alternatives: Sequence[Alternative]) -> np.ndarray:
    """Each alternative's share of the open mixture: every open effect the same prior share, split between
    its parameters the fit profiles one at a time (a registration offset's x and y), each weighed by its
    evidence (`Profile.evidence`), normalised. Every alternative holds the fitted world at its default, so
    the mixture never leaves out the world without them; one whose range the fit cells mostly exclude
    weighs less."""
    if not alternatives:
        return np.zeros(0)
    kinds = Counter(a.profile.candidate.kind for a in alternatives)
    evidence = np.array(
        [a.profile.evidence() - math.log(kinds[a.profile.candidate.kind]) for a in alternatives]
    )
    weights = np.exp(evidence - evidence.max())
    return weights / weights.sum()


def allowed_values(fitted: Profile, before: float) -> tuple[float, ...]:
    """The grid values of `fitted` whose fit-cell log-likelihood is within χ²₁,₀.₉₅ / 2 of `before` (the
    world without it) or better: those the fit cells cannot exclude."""
    return tuple(v for v, total in zip(fitted.values, fitted.total) if 2 * (before - total) < LR_95)


def open_effects(
    mapper: Mapper,
    base: WorldEffects,
    before: np.ndarray,
    cells: Sequence[Cell],
    transfers: int,
    points: int,
    informative: int,
    phases: bool,
) -> list[Alternative]:
    """Every candidate of a kind not in `base` (the fitted world; `before` its per-cell log-likelihoods on
    the fit `cells`) profiled on top of it, and those whose values the fit cells cannot exclude as
    alternatives, each at its allowed value farthest from the default. A value is judged against `base`
    simulated on the same seeds and as many transfers (`Profile.reference`): the fitted world was weighed
    on more (`fit`'s `weighed`)."""
    others = [c for c in candidates(points) if c.kind not in {effect.kind for effect in base}]
    worlds = [candidate.world(value, base) for candidate in others for value in candidate.grid]
    simulate_cells(mapper, worlds, [c.key for c in cells[:informative]], transfers)  # one batch
    out = []
    for candidate in others:
        fitted = profile(
            mapper, candidate, cells, transfers, before, informative, base, phases, every_cell=True
        )
        reference = before if fitted.reference is None else fitted.reference
        allowed = allowed_values(fitted, float(reference.sum()))
        if not allowed:
            continue
        p = WORLD_EFFECT_KINDS[candidate.kind].parameters[candidate.parameter]
        value = max(allowed, key=lambda v: abs(v - p.default) / (p.high - p.low))
        out.append(Alternative(fitted, allowed, value))
    return out


def changes_held_out(
    mapper: Mapper,
    base: WorldEffects,
    alternatives: Sequence[Alternative],
    held_out: Sequence[Cell],
    transfers: int,
    first_seed: int,
) -> list[Alternative]:
    """Those of `alternatives` whose simulated counts in a `held_out` cell differ from `base`'s on the same
    seeds: the alternatives that change a prediction."""
    keys = [c.key for c in held_out]
    if not keys or not alternatives:
        return []
    sims = simulate_cells(mapper, [base, *(a.world() for a in alternatives)], keys, transfers, first_seed)
    return [
        a
        for a, sim in zip(alternatives, sims[1:])
        if any(not np.array_equal(sim[k].vector(), sims[0][k].vector()) for k in keys)
    ]
