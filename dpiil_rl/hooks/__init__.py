"""Training-loop hooks: each a small TorchRL TrainerHookBase with register/state_dict/load_state_dict."""
