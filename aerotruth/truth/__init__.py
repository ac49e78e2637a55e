"""Truth: JSBSim flights through a truth atmosphere on real airline routes."""
