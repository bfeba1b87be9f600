"""Several objects at once: per-sensor tracking into segments, association across sensors."""
