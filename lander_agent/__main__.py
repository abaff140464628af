from bus.process import main_for

main_for("lander", "lander_agent.commands.lander")
