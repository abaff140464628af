"""The radio: the communication graph of ranges and lines of sight (``graph``), each sender's capacity
(``airtime``), and the world's part that delivers transmissions along the graph (``link``)."""
