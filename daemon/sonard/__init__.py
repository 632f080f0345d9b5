"""sonard: the acquisition daemon for the Nomad 200 sonar ring."""
