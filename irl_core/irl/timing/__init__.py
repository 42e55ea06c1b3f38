"""Care from timing (docs/timing.md): a time world's player, who holds a key for a time, not a level.

==============  ========================================================================
`slip_curve`    the slip curve p(d), fitted to the recorded slips with profile intervals
`fit`           the rewards, the curve and the player from the exact holds, with sandwich
                intervals of their own
==============  ========================================================================
"""
