"""What rovers sense of the world: the world's part that publishes each tick's readings (``readings``) and the
perception scan of many rovers at once (``perception``)."""
