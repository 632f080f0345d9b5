"""Plane geometry the surface stages share: runs of one array, polylines, feet, searches.

Nothing here knows about sonar: ragged runs (:mod:`.runs`), polylines and distances to
them (:mod:`.polylines`), feet of points on segments (:mod:`.feet`), and the nearest
point and ball searches over :class:`scipy.spatial.cKDTree` (:mod:`.search`).
"""
