//! Convex polygons clipped by half-planes (being written).
