"""The object's volume: what the visual hull gives the stroke set besides curves.

- :mod:`.abstraction`  the compact abstraction: superquadrics fitted to the hull in 3D (the default outline)
- :mod:`.outlines`     which superquadrics draw their outline, and where the views confirm it
- :mod:`.hull`         the hull's thick part (the older silhouette fit), the coarse occluder, and the hull whose
  outline ``--outline hull`` draws
"""
