"""The building behind a Flectofold facade, simulated with EnergyPlus (no ROS).

- :mod:`.energyplus_model`: a shoebox office behind a shading facade as an epJSON document, a
  runner through the EnergyPlus runtime API that reads the period's figures from its SQLite
  output, and the run-time actuation of the facade's transmittance schedule.
"""
