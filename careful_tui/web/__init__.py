"""`careful serve`: the study for participants in a web browser (docs/browser.md).

`session_adapter` is a participant's way through the study, `seats` keeps one page per participant
and bounds its keys, `links` writes and reads the participant links, `server` is the ASGI app and
`static/` the one page it serves.
"""
