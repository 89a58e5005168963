"""Methods as plug-ins: each is one module here, one configs/method/<name>.yaml and one test file."""
