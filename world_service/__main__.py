from bus.process import main_for

main_for("world", "world_service.commands.world")
