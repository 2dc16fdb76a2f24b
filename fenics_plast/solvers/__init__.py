"""Solvers: static (SNES Newton, increments, cut-back) and explicit (central differences)."""
