"""ugpcl's moderngl front end: one View per scene, a shared window (``ugpcl-view``) and an EGL offscreen path."""
