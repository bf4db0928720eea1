"""The Helix-25 plant: what the rover's body does with its four scrolls, apart from any autopilot.

Thesis eq. 1 written out on its own (:mod:`helixd.plant.forward`), motor lag, terrain traction
and pits (:mod:`helixd.plant.physics`, the ground table :mod:`helixd.plant.ground`), ArduPilot
SITL's skid-steer rover (:mod:`helixd.plant.skid`), obstacles (:mod:`helixd.plant.collisions`),
the pond's bottom and its sonar (:mod:`helixd.plant.sonar`), the media map and the bottom
placed around the world's origin (:mod:`helixd.plant.world`) and the plant's settings
(:mod:`helixd.plant.plant_config`). Two products stand on it: the built-in ArduPilot simulator
(:mod:`helixd.sim`) and real ArduPilot SITL's physics over its JSON interface
(:mod:`helixd.plant.json_physics`, :mod:`helixd.plant.json_server`; ``helixd plant``). Pure,
except the JSON server's socket.
"""
