"""Model descriptions: the catalogue, user model files, named errors."""
