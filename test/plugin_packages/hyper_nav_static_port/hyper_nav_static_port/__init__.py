"""A second static-pressure port: a new sensor in its own package (model, node, descriptor)."""
