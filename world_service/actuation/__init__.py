"""What rovers do when their agents ask: the world's part that answers actions and steps the bodies
(``actuator``), the kinematics of a move and a rotation (``navigation``), the checks an action passes and the
ground's noise (``checks``), collisions (``contacts``), and the memory of each rover's last action that makes the
protocol survive lost samples (``ledger``)."""
