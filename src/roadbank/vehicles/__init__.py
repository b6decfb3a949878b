"""Shipped vehicle files (``*.toml``), loaded by name with :func:`roadbank.vehicle.load_vehicle`.

See ``docs/vehicles.md`` for the format and the sources of every car.
"""
