"""helixd configuration (``config/helixd.yaml``), validated by pydantic.

Every tunable lives here with its unit (in the name or the description), its bounds and a
default taken from the Helix-25 thesis (docs/physics.md). Unknown keys are errors. Loading a bad
file raises :class:`~helixd.files.models.ConfigFileError` carrying one message per problem,
each naming the file, the dotted field path, the bad value and what is allowed (the machinery:
helixd.files.models).

One module per group of sections; this package re-exports nothing, import each name from its
module:

* :mod:`helixd.config.vehicle`: ``vehicle`` and ``actuation``;
* :mod:`helixd.config.control`: ``control`` (PID gains, line guidance, slip estimate);
* :mod:`helixd.config.mission`: ``mission`` and ``planning``;
* :mod:`helixd.config.media`: ``media`` and ``ground``;
* :mod:`helixd.config.link`: ``link``;
* :mod:`helixd.config.safety`: ``safety`` and ``startup``;
* :mod:`helixd.config.recorder`: ``recorder``, ``payload`` and ``gcs_report``;
* :mod:`helixd.config.serve`: ``serve``;
* :mod:`helixd.config.root`: :class:`HelixdConfig`, the whole file, and the rules between
  sections;
* :mod:`helixd.config.load`: which file a command reads, loading it, writing it back;
* :mod:`helixd.config.fields`: validators and field types the sections share.
"""
