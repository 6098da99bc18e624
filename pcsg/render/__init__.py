"""From traced rays to images: camera, shading, sampling, output."""
