"""Package meshes."""
