from rover_agent.app import main

main()
