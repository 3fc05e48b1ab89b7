"""Reports for people: the parameter-uncertainty page and `roboball report --params`."""
