"""Can a classifier tell generated head motion from recorded heads: the two-sample test (:mod:`.detectability`) and its network classifier (:mod:`.detectability_cnn`)."""
