"""The chapters: one module per chapter, each holding its ``Params``, ``Simulation`` and ``SCENES``.

``ugpcl.registry`` finds them by file stem; nothing here is imported by hand.
"""
