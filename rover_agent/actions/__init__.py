"""The agent's actions: the one in flight (``in_flight``), the ids they carry (``ids``), the speed level sent with
moves (``pace``), and the tracker that holds them for the agent (``tracker``)."""
