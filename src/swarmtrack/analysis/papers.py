"""The papers' published numbers, as printed (units converted to metres and m/s).

L24 Tables 1-3: RMSE mean over the three UAVs, cm and cm/s in the paper. L23 Table 1: std of the estimates,
m and m/s, mean over the three UAVs.
"""

L24_RMSE = {  # model -> phase -> [x, y, vx, vy], metres / m/s
    "cv": {"linear": [0.0830, 0.0196, 0.0759, 0.0302], "sinusoidal": [0.0677, 0.2055, 0.0728, 0.2340],
           "circular": [0.2711, 0.2771, 0.4740, 0.4821], "total": [0.2077, 0.2325, 0.3554, 0.3767]},
    "ct": {"linear": [0.0647, 0.0212, 0.1851, 0.0429], "sinusoidal": [0.0818, 0.2344, 0.0851, 0.2094],
           "circular": [0.2676, 0.2580, 0.1132, 0.1518], "total": [0.2053, 0.2254, 0.1259, 0.1552]},
    "fs": {"linear": [0.0648, 0.0468, 0.1380, 0.1537], "sinusoidal": [0.0626, 0.1485, 0.1073, 0.1217],
           "circular": [0.1824, 0.1973, 0.3395, 0.3402], "total": [0.1422, 0.1670, 0.2649, 0.2704]},
}

L23_SPREAD = {  # fusion -> [x, y, vx, vy]
    "no-fusion": [0.2647, 0.3903, 0.1328, 0.1285],
    "full-fusion": [0.1333, 0.1149, 0.0762, 0.0619],
}
