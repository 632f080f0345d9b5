"""From the arc-count map to ordered surfaces: ridge, paths through it, corners.

:mod:`.ridge` thins the count map across each ridge's own direction; :mod:`.extract`
pools the kept cells into nodes, joins them (:mod:`scipy.sparse.csgraph`) and orders
each group along its longest path (:mod:`.paths`), cut at :mod:`.corners`;
:mod:`.coarse` is the coarse count map of long logs.
"""
