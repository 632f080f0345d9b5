"""Fits against a multi-surface truth, and the files that hold them.

:mod:`.seen` keeps the truth the sonars could see, :mod:`.truth` measures precision and
completeness against it, :mod:`.writers` writes ``surfaces.csv`` and GeoJSON.
"""
