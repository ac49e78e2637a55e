"""aerotruth: JSBSim truth flights, airborne sensor error models, the wind paper's
heading-deviation correction and the FITS paper's WAAS-aided flight-inspection truth,
run as seeded Monte-Carlo campaigns."""

__version__ = "0.1.0"
