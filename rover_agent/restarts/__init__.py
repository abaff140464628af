"""What survives a restart of the agent: the state it saves with every action (``saved_state``) and how it takes
that up again, or knows it is lost, on the first clock of a run (``resume``)."""
