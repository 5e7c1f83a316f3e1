"""The ``fibrecut`` command: solver commands (:mod:`cli.main`), analyses (:mod:`cli.analysis`) and
study commands over the REST API (:mod:`cli.study`, :mod:`cli.client`)."""
