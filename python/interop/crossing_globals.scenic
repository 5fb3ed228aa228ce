# A pedestrian crossing in front of a car, in Scenic's built-in Newtonian simulator (no
# external simulator): the car drives north at 10 m/s, the pedestrian walks west across its
# path 32.5 m ahead. φ: where the pedestrian starts and how fast it walks (global parameters drawn from Ranges).
param render = False
model scenic.simulators.newtonian.model

param ped_speed = Range(0.5, 3.0)
param ped_start = Range(2.0, 12.0)

ego = new Object at (0, 0), with velocity (0, 10), with width 1.8, with length 4.5
ped = new Object at (globalParameters.ped_start, 32.5), with velocity (-globalParameters.ped_speed, 0),
    with width 0.6, with length 0.6
