"""Policy serving (paper A.4): ``pipette serve``'s ZeroMQ server, its client and the msgpack wire
protocol (:mod:`.protocol`, never pickle). Only :mod:`.server` loads a LeRobot policy."""
