"""The object's volume: what the visual hull gives the stroke set besides curves.

- :mod:`.carve`        the visual hull, carved once per fit on a grid fitted to the object
- :mod:`.abstraction`  the compact abstraction: superquadrics fitted to the hull in 3D (the default outline)
- :mod:`.outlines`     which superquadrics draw their outline, and where the views confirm it
- :mod:`.silhouettes`  the superquadrics' silhouettes against the masks, and the pixels their outlines take
- :mod:`.hull`         the hull's thick part (for the silhouette fit), the coarse occluder, and the hull whose
  outline ``--outline hull`` draws
"""
