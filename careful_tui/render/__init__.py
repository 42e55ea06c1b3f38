"""Pictures without a terminal app: Rich renderables and matplotlib figures.

- `palette`: the colours, named by meaning (the Textual theme is built from them).
- `grid`: `WorldGrid`, a world drawn as coloured cells, and the signed-log reward colours.
- `session`: how an episode ended, a world's legend, a recording's summary panel.
- `fit_printout`, `intervals`: a fit as the `careful fit` printout and the fit screen draw it.
- `fit_panels`: the fit screen's notes, intervals, policy key and settings line.
- `worlds`: `careful worlds`'s table and a world's drawing.
- `reach_field`, `reach_fit`: a reach world's field in text; a reach fit printed and drawn for its fit view.
- `study_words`: a study's words for its participant (`irl_core.studies.words`) in the palette's colours.
- `figures`: matplotlib figures for papers (imported only by `careful fit --figure` and
  `careful experiment`).

May import: `irl_core`, Rich, matplotlib (in `figures`). Never Textual.
"""
