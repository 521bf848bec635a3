"""Comparing renders — two SVG/PNG/PDF files → a verdict: do they look the same?

:mod:`.compare` renders both at one size and counts the pixels that differ (``depixel diff``).
"""
