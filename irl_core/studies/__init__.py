"""Studies of many participants (floor 7, the top): the study file and its resume protocol
(`study`), a participant's flow through instructions, practice and main blocks (`flow`), the lock
that keeps one participant to one writer (`participant_lock`), simulated participants
(`simulated`) and the study's report, fitted and pooled (`report`).

May import: every wing below it.
"""
