"""Public speech-and-motion corpora, read in their own layouts and imported as a headmotion corpus.

The seeds record their own corpora (thesis §3.3–3.5; paper §4.1); researchers today train and
compare on public releases.  :func:`import_dataset` reads one of :data:`LAYOUTS` and writes a
``corpus.csv`` that points at the files where they are (nothing is copied), keeping the dataset's
own train / valid / test split as the manifest's ``split`` column:

* ``beat2`` — BEAT2 (``smplxflame_30/*.npz`` SMPL-X at 30 fps, ``wave16k/*.wav``,
  ``train_test_split.csv``); speaker from the file name (``2_scott_0_1_1`` → ``scott``).
* ``amass`` — an AMASS-style folder of SMPL-X / SMPL-H ``.npz`` takes (any depth) with the speech
  of each take, same stem, in an audio folder; speaker from the take's parent folder.

Every pair is checked at import with the rule every later command applies
(:func:`headmotion.align.recording_tolerance_s`): trimmed to the shorter track when speech and
motion differ by at most 1 s and 2 %, refused beyond, naming both lengths.
"""

from .importer import LAYOUTS, DatasetItem, ImportSummary, import_dataset, import_items
from .pairs import PairCheck, check_pair

__all__ = ["LAYOUTS", "DatasetItem", "ImportSummary", "import_dataset", "import_items", "PairCheck", "check_pair"]
