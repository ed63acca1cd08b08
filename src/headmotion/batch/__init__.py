"""Many speech files to motion files in one call (``headmotion synth IN... -o DIR``).

:func:`synthesize_batch` (:mod:`.run`) is the Python form of the command: the inputs and the
names of their outputs are :mod:`.inputs`, the record that lets a second run skip what is up to
date is :mod:`.manifest`.
"""

from .run import BatchResult, synthesize_batch

__all__ = ["BatchResult", "synthesize_batch"]
