"""One curve per surface: lines, arcs and splines, one implementation each, and the choice.

:mod:`.lines` (total least squares), :mod:`.arcs` (Kasa + Gauss-Newton circles) and
:mod:`.splines` (smoothing splines in arc length, through :mod:`sonarproc.fit`'s one
smoothing spline) fit the candidates; :mod:`.models` holds what they return and the
criterion that picks one; :mod:`.batch` fits many surfaces at once; :mod:`.bends` splits
a spline that is two straight walls meeting at a corner into their lines; :mod:`.merge`
joins collinear pieces.
"""
