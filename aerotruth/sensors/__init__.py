"""Sensor error models: each a Spec (from config) -> draw(rng) -> Errors.apply(truth)."""
