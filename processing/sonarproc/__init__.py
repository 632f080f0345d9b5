"""sonarproc: sonar arc maps, morphological processing and surface-profile fitting."""
