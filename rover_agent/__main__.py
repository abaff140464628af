from deploy.process import main_for

main_for("rover", "rover_agent.app")
