"""How sure a fit is: the intervals of docs/answers.md, one module per kind, and a fit's choice among them.

==============  ==========================================================================
`identified`    lp: every value the demonstrations allow (the range over the lp set)
`bootstrap`     maxent and loss: a confidence interval from refits of resampled episodes
`of_fit`        a fit's intervals, of its method's kind, widened where resampling cannot move
==============  ==========================================================================

A model of people's Laplace intervals live with the models (`irl_core.irl.people.laplace`), and the
timing fit's sandwich intervals with it (`irl_core.irl.timing.fit`).
"""
