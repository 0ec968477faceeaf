"""The questionnaire figure's group labels never overlap one another or the panels' axis texts,
measured on the text extents the Agg renderer gives (not on pixels), and keep all their words."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from nudgecli.report.figures.questionnaires import group_label, questionnaire_figure
from nudgecli.report.plans import load_plan

CONDITIONS = ["control", "disambiguation"]
TLX_SIX = ["mental", "physical", "temporal", "performance", "effort", "frustration"]


def _tables(tlx: list[str], likert: list[str], seed: int = 3) -> tuple[pd.DataFrame, pd.DataFrame]:
    rng = np.random.default_rng(seed)
    rows = [{"participant": p, "condition": c, **{f"tlx_{k}": rng.uniform(10, 60) for k in tlx},
             **{f"likert_{q}": int(rng.integers(1, 8)) for q in likert}}
            for p in range(5) for c in CONDITIONS]
    frame = pd.DataFrame(rows)
    ids = ["participant", "condition"]
    return frame[ids + [f"tlx_{k}" for k in tlx]], frame[ids + [f"likert_{q}" for q in likert]]


def _boxes(texts, renderer) -> list:
    return [t.get_window_extent(renderer) for t in texts if t.get_visible() and t.get_text()]


def _touch(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


CASES = {
    # the six TLX subscales with both scores beside the study's four statements: both panels crowded
    "eight scales": ([*TLX_SIX, "raw", "weighted"], ["q3", "q4", "q7", "q10"]),
    # ten Likert items beside two scores: the Likert panel's groups narrow
    "ten items": (["raw", "weighted"], [f"q{i}" for i in range(1, 11)]),
    # the paper's figure: wide enough, kept as drawn before
    "paper": (["raw", "weighted"], ["q3", "q4", "q7", "q10"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_group_labels_do_not_overlap_each_other_or_the_axis_texts(case: str) -> None:
    tlx_names, likert_names = CASES[case]
    tlx, likert = _tables(tlx_names, likert_names)
    labels = load_plan("paper").questionnaires.labels
    fig = questionnaire_figure(tlx, likert, conditions=CONDITIONS, item_labels=labels)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    axes = fig.get_axes()
    for ax in axes:
        ticks = _boxes(ax.get_xticklabels(), renderer)
        assert len(ticks) == len(ax.get_xticks())
        for a, b in itertools.pairwise(ticks):
            assert a.x1 <= b.x0, (case, a, b)  # left to right, apart
        for box in ticks:
            assert box.x0 >= 0 and box.x1 <= fig.bbox.width  # inside the figure
        for other in axes:
            texts = [other.yaxis.label, *other.get_yticklabels()]
            if other is not ax:
                texts += list(other.get_xticklabels())
            assert not any(_touch(a, b) for a in ticks for b in _boxes(texts, renderer)), case
    # every word of every label is still there, in order (wrapped, never cut)
    names = [*(f"tlx_{k}" for k in tlx_names), *(f"likert_{q}" for q in likert_names)]
    shown = [" ".join(t.get_text().split()) for ax in axes for t in ax.get_xticklabels()]
    assert shown == [" ".join(group_label(n, labels).replace(": ", " ", 1).split()) for n in names]


def test_labels_that_fit_keep_the_widest_wrap_and_the_style_size() -> None:
    tlx, likert = _tables(["raw", "weighted"], ["q3", "q4", "q7", "q10"])
    labels = load_plan("paper").questionnaires.labels
    fig = questionnaire_figure(tlx, likert, conditions=CONDITIONS, item_labels=labels)
    ticks = fig.get_axes()[1].get_xticklabels()
    assert ticks[0].get_text() == "Q3\nfigured out\nmy goal more\neasily"  # 13 characters a line
    assert len({t.get_fontsize() for ax in fig.get_axes() for t in ax.get_xticklabels()}) == 1
