"""Statistical models shared by the systems (GMM regression, HMMs, networks) and model files."""
