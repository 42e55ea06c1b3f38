"""A study report's table: its CSV rows (`report_rows`) and what each world's pooled row shows (`pooled_finding`)."""

from __future__ import annotations

import numpy as np

from irl_core.experiment.claims import SYMBOL_WORDS, interval_text, number_text, order_words
from irl_core.studies.population import outlier_reach
from irl_core.studies.report_cells import POOLED, Cell, StudyData
from irl_core.studies.report_fits import CellFit
from irl_core.studies.study import LoadedStudy
from irl_core.support.csv_cells import text_cell

# Per fitted symbol S: reward_S, then these suffixes (a population's spread and prediction interval last).
# Past this, the finding says how weak the outlier test is with so few participants (`outlier_reach`): over three
# rewards, 7 participants are past it (1.65) and 8 are not (1.48).
WEAK_OUTLIER_TEST = 1.5
REWARD_COLUMNS = ("", "_low", "_high", "_spread", "_pred_low", "_pred_high")


def report_symbols(study: LoadedStudy, fits: list[CellFit]) -> list[str]:
    """Every fitted symbol of any world, worst true reward first (cliff, mud, ..., goal)."""
    symbols = {s for f in fits for s in f.symbols}
    truth = {s: min(w.reward_of(s) for w in study.grid_worlds if s in w.layout) for s in symbols}
    return sorted(symbols, key=lambda s: (truth[s], s))


def report_rows(data: StudyData, fits: list[CellFit]) -> tuple[list[str], list[list[str]]]:
    """The report's CSV: its columns and one row per cell (world by world: participants, then the pool).

    Columns: study, participant, world_index, world, show_rewards (``true`` or ``false``: whether the board's
    legend gave the participants each symbol's reward, the study file's), episodes, steps, interrupted,
    ``ended_<T>`` per terminal symbol, step_limit, careful_next_to_terminal, hold_ms_next_to_terminal, method, beta,
    interval_kind, confidence, pool_model (a pool's row: ``population`` or ``shared``), ``reward_<S>``,
    ``reward_<S>_low``, ``reward_<S>_high``, ``reward_<S>_spread``, ``reward_<S>_pred_low``,
    ``reward_<S>_pred_high`` per fitted symbol (the last three on a population's row: the spread between
    participants and the prediction interval for a new one), files_left_out, note, fit_check (``passed``
    or ``failed``), outlier and influential (a participant's row: ``true`` or ``false``; a pool's: the
    participants marked, space-separated, or ``none``), excluded (``true`` or ``false``) and excluded_why
    (a participant's row), finding (a pool's row: `pooled_finding`). Empty where a value does not apply.
    """
    study = data.study
    terminals = sorted({t for w in study.grid_worlds for t in w.terminal})
    symbols = report_symbols(study, fits)
    columns = ["study", "participant", "world_index", "world", "show_rewards", "episodes", "steps", "interrupted",
               *(f"ended_{t}" for t in terminals), "step_limit", "careful_next_to_terminal",
               "hold_ms_next_to_terminal", "method", "beta",
               "interval_kind", "confidence",
               "pool_model", *(f"reward_{s}{end}" for s in symbols for end in REWARD_COLUMNS), "files_left_out",
               "note", "fit_check", "outlier", "influential", "excluded", "excluded_why", "finding"]
    rows = []
    for cell, result in zip(data.cells, fits):
        world = study.grid_worlds[cell.world_index]
        rewards: list[str] = []
        for symbol in symbols:
            if symbol in result.symbols:
                j = result.symbols.index(symbol)
                rewards += _reward_cells(result, j)
            else:
                rewards += [""] * len(REWARD_COLUMNS)
        terminal_counts = [str(cell.outcomes.get(t, 0)) if t in world.terminal else "" for t in terminals]
        rows.append([
            text_cell(study.study.name), cell.participant, str(cell.world_index), text_cell(world.name),
            _flag(study.study.show_rewards), str(cell.episodes),
            str(cell.steps), str(cell.interrupted), *terminal_counts, str(cell.outcomes.get("step_limit", 0)),
            _number(cell.careful_next_to_terminal), _number(cell.hold_ms_next_to_terminal), result.method, _number(result.beta),
            result.interval_kind or "", _number(result.confidence) if result.interval_kind == "confidence" else "",
            result.pool_model or "", *rewards,
            str(data.left_out.get(cell.participant, 0)) if cell.participant != POOLED else "",
            text_cell(result.error or "; ".join(str(note) for note in result.notes)),
            _flag(result.fit_check_passed, "passed", "failed"),
            _flag(result.outlier) if cell.participant != POOLED else " ".join(result.outliers) or
            ("none" if result.pool_model == "population" else ""),
            _influence_cell(result),
            "" if cell.participant == POOLED else _flag(result.excluded_why is not None),
            text_cell(result.excluded_why or ""),
            text_cell(pooled_finding(data, cell, result)) if cell.participant == POOLED else "",
        ])
    return columns, rows


def _reward_cells(result: CellFit, j: int) -> list[str]:
    """A reward's cells (`REWARD_COLUMNS`): the estimate, its interval, and a population's spread and prediction."""
    low, high = ("", "") if result.intervals is None else (_number(v) for v in result.intervals[j])
    spread = "" if result.spread is None else _number(result.spread[j])
    pred_low, pred_high = ("", "") if result.prediction is None else (_number(v) for v in result.prediction[j])
    return [_number(result.estimate[j]), low, high, spread, pred_low, pred_high]


def _flag(value: bool | None, yes: str = "true", no: str = "false") -> str:
    return "" if value is None else yes if value else no


def _influence_cell(result: CellFit) -> str:
    if result.pool_model == "population":
        return " ".join(result.influencers) or "none"
    if result.influential is not None:
        return "true" if result.influential else "false"
    if result.influence is not None:
        return " ".join(result.influential_participants) or "none"
    return ""


def pooled_finding(data: StudyData, cell: Cell, result: CellFit) -> str:
    """What a world's pooled row shows, in a sentence from its numbers: whether the pooled interval of
    the worst hazard (a terminal symbol with the most negative reward) lies below the nuisance's
    (a non-terminal one with a negative reward), as carefulness should make it; which intervals miss
    the world's rewards; who is influential.

    "mud: the pooled cliff interval [-1420, -869] lies below the mud's [-52, -24]: carefulness
    separates catastrophe from nuisance; every interval covers the world's reward; no participant
    alone moves a pooled reward out of its interval."

    A population's row says so ("the population's cliff interval"), and names its outliers and influential
    participants and those the study's exclusions left out.
    """
    world = data.study.grid_worlds[cell.world_index]
    if result.error:
        return f"{world.name}: no pooled fit ({result.error})."
    if result.intervals is None:
        return f"{world.name}: no pooled interval (see the note), so nothing to compare."
    truth = dict(zip(result.symbols, result.truth))
    interval = {s: (float(low), float(high)) for s, (low, high) in zip(result.symbols, result.intervals)}
    hazards = sorted((truth[s], s) for s in result.symbols if s in world.terminal and truth[s] < 0)
    nuisances = sorted((truth[s], s) for s in result.symbols if s not in world.terminal and truth[s] < 0)
    parts = []
    whose = "population's" if result.pool_model == "population" else "pooled"
    if hazards and nuisances:
        hazard, nuisance = hazards[0][1], nuisances[0][1]
        h, n = _word(hazard), _word(nuisance)
        order = order_words(interval[hazard], interval[nuisance])
        said = {"below": "lies below", "above": "lies above", "overlaps": "overlaps"}[order]
        verdict = {"below": "carefulness separates catastrophe from nuisance" if world.levels > 1 else
                            "they lie apart, though with one level of carefulness it is the model's assumptions, "
                            "not carefulness, that separate them",
                   "above": f"the {n} comes out worse than the {h}",
                   "overlaps": "these participants' play does not separate catastrophe from nuisance"}[order]
        parts.append(f"the {whose} {h} interval {interval_text(interval[hazard])} {said} the {n}'s "
                     f"{interval_text(interval[nuisance])}: {verdict}")
    elif hazards:
        parts.append(_signs(hazards[0][1], interval, [s for s in result.symbols if truth[s] > 0]))
    missed = [f"the {_word(s)}'s interval misses the world's {truth[s]:g}" for s in sorted(result.symbols, key=truth.__getitem__)
              if not interval[s][0] <= truth[s] <= interval[s][1]]
    parts.append("; ".join(missed) if missed else "every interval covers the world's reward")
    if result.pool_model == "population":
        parts.append(_population_marks(data, cell, result))
    elif result.influence:
        parts.append(_influence_words(result))
    return f"{world.name}: " + "; ".join(p for p in parts if p) + "."


def _population_marks(data: StudyData, cell: Cell, result: CellFit) -> str:
    """Who the population's row marks and who the exclusions left out, in words from the marks."""
    said = []
    for names, what in ((result.outliers, "outside where the others say a participant's fit would lie"),
                        (result.influencers, "moving the population's centre out of an interval alone")):
        if names:
            said.append(f"{' and '.join(names)} {'is' if len(names) == 1 else 'are'} {what} "
                        f"({'outlier' if what.startswith('outside') else 'influential'})")
    n = result.pooled or 0
    reach = outlier_reach(n, rewards=len(result.symbols), confidence=result.confidence or 0.95)
    if n < 3:
        return f"with {n} participants nobody is tested as an outlier or for influence"
    if not result.outliers and np.isinf(reach):
        if not result.influencers:
            said.append("nobody moves the centre alone")
        said.append(f"with {n} participants nobody can be found an outlier (too few others to say where a fit "
                    "would lie)")
    elif not said:
        said.append("no participant is an outlier or moves the centre alone")
        if reach > WEAK_OUTLIER_TEST:
            said.append(f"with {n} participants the outlier test finds only fits far outside the others (its "
                        f"interval is {reach:.1f} times as wide as with many participants)")
    return "; ".join(said)


def _signs(hazard: str, interval: dict[str, tuple[float, float]], goals: list[str]) -> str:
    """Whether the hazard's pooled interval lies below 0 and the goals' above, in a world without a nuisance."""
    h = _word(hazard)
    below = interval[hazard][1] < 0
    text = f"the pooled {h} interval {interval_text(interval[hazard])} {'lies' if below else 'does not lie'} below 0"
    for goal in goals:
        above = interval[goal][0] > 0
        text += (f"{' and' if above == below else ', but'} the {_word(goal)}'s {interval_text(interval[goal])} "
                 f"{'lies' if above else 'does not lie'} above it")
    return text


def _word(symbol: str) -> str:
    return SYMBOL_WORDS.get(symbol, repr(symbol))


def _influence_words(pooled: CellFit) -> str:
    """"without p07 the cliff -361, outside the pooled interval: ...", or that no one alone moves the pool
    and who moves it most."""
    assert pooled.influence
    moved = [i for i in pooled.influence if i.outside]
    if not moved:
        most = max(pooled.influence, key=lambda i: i.shift)
        if not most.most:
            return "no participant alone moves a pooled reward out of its interval"
        value = dict(most.without)[most.most]
        pooled_value = pooled.estimate[pooled.symbols.index(most.most)]
        return (f"no participant alone moves a pooled reward out of its interval (the most: without "
                f"{most.participant} the {_word(most.most)} {number_text(value)} against {number_text(pooled_value)})")
    said = []
    for influence in moved:
        values = " and ".join(f"the {_word(symbol)} {number_text(value)}" for symbol, value in influence.without
                              if symbol in influence.outside)
        said.append(f"without {influence.participant} {values}")
    several = len(moved) > 1 or len(moved[0].outside) > 1
    return (f"{'; '.join(said)}, outside the pooled interval{'s' if several else ''}: "
            f"{'this participant moves' if len(said) == 1 else 'each of these participants moves'} the pool alone")


def _number(value: float | None) -> str:
    """A number for the CSV: empty for None, else up to 6 significant digits."""
    return "" if value is None or not np.isfinite(value) else f"{float(value):.6g}"
