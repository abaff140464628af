"""The rovers' cameras: the world's part that takes photos one at a time (``shutter``), what a photo froze and the
process that renders it (``photos``), how an image is made from the ground truth (``rendering``), and the service's
side, which hands out photos when they are due (``photographer``)."""
