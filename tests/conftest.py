"""Shared test helpers live beside this file (`tmux_terminal`); pytest puts this folder on sys.path."""
