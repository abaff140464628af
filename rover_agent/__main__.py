from rover_agent.commands.rover import main

main()
