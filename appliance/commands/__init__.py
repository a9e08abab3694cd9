"""One module per `appliance` command; each only parses, calls and prints."""
