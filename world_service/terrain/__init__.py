"""The ground's shape: the tiled heightmap the world samples (``heightmap``), built from landforms (``landforms``:
undulation and craters) or a mesh (``mesh``); the compiled grid the camera marches rays in (``height_grid``); views
of the heightmap for the camera's process (``views``); and its export for other viewers (``export``)."""
