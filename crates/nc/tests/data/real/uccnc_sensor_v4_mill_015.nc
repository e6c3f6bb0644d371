(RS-274 Compatible G-code generated for UCCNC controller and Stepcraft 2 Mill)
(Created by in EagleCAD with the stepcraft.ulp 0.2.)
(File: "sensor_v4.brd" created on: 4/26/16 7:52 AM)
(Use a 1/64inch Bit)

G90 G94 G49
G21
G00 Z5
G00 X0Y0
S19500 M03
G04 P4000
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X12.446Y46.228
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X17.653Y46.228 F144
(-->Cutting Line)
G01 X18.796Y47.371 F144
(-->Cutting Line)
G01 X18.796Y49.403 F144
(-->Cutting Line)
G01 X20.320Y50.927 F144
(-->Cutting Line)
G01 X21.844Y50.927 F144
(-->Cutting Line)
G01 X22.606Y51.689 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X24.384Y56.388
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X24.384Y54.229 F144
(-->Cutting Line)
G01 X24.257Y54.102 F144
(-->Cutting Line)
G01 X22.606Y54.102 F144
(-->Cutting Line)
G01 X22.606Y51.689 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X22.098Y48.260
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X20.701Y48.260 F144
(-->Cutting Line)
G01 X20.701Y49.149 F144
(-->Cutting Line)
G01 X21.336Y49.149 F144
(-->Cutting Line)
G01 X22.352Y50.165 F144
(-->Cutting Line)
G01 X24.384Y50.165 F144
(-->Cutting Line)
G01 X25.146Y50.927 F144
(-->Cutting Line)
G01 X25.146Y52.070 F144
(-->Cutting Line)
G01 X26.924Y53.848 F144
(-->Cutting Line)
G01 X30.480Y53.848 F144
(-->Cutting Line)
G01 X31.623Y52.705 F144
(-->Cutting Line)
G01 X31.623Y50.292 F144
(-->Cutting Line)
G01 X29.718Y50.292 F144
(-->Cutting Line)
G01 X29.083Y50.927 F144
(-->Cutting Line)
G01 X29.083Y52.197 F144
(-->Cutting Line)
G01 X28.575Y52.705 F144
(-->Cutting Line)
G01 X27.305Y52.705 F144
(-->Cutting Line)
G01 X26.416Y51.816 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X22.733Y49.276
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X22.479Y49.022 F144
(-->Cutting Line)
G01 X22.479Y48.514 F144
(-->Cutting Line)
G01 X22.225Y48.260 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.416Y51.816
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X26.416Y49.276 F144
(-->Cutting Line)
G01 X25.146Y49.276 F144
(-->Cutting Line)
G01 X22.733Y49.276 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.416Y49.276
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X26.416Y48.133 F144
(-->Cutting Line)
G01 X27.051Y48.133 F144
(-->Cutting Line)
G01 X28.702Y48.133 F144
(-->Cutting Line)
G01 X28.702Y49.149 F144
(-->Cutting Line)
G01 X31.369Y49.149 F144
(-->Cutting Line)
G01 X31.369Y40.640 F144
(-->Cutting Line)
G01 X31.369Y38.862 F144
(-->Cutting Line)
G01 X30.353Y37.846 F144
(-->Cutting Line)
G01 X29.083Y37.846 F144
(-->Cutting Line)
G01 X26.670Y37.846 F144
(-->Cutting Line)
G01 X26.289Y37.465 F144
(-->Cutting Line)
G01 X26.289Y37.084 F144
(-->Cutting Line)
G01 X26.289Y36.957 F144
(-->Cutting Line)
G01 X27.940Y36.957 F144
(-->Cutting Line)
G01 X30.861Y36.957 F144
(-->Cutting Line)
G01 X32.258Y38.354 F144
(-->Cutting Line)
G01 X32.258Y49.657 F144
(-->Cutting Line)
G01 X31.496Y50.419 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X28.702Y48.006
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X28.702Y46.355 F144
(-->Cutting Line)
G01 X30.099Y46.355 F144
(-->Cutting Line)
G01 X30.099Y44.895 F144
(-->Cutting Line)
G01 X27.051Y44.895 F144
(-->Cutting Line)
G01 X27.051Y48.133 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X25.146Y49.276
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X25.146Y48.228 F144
(-->Cutting Line)
G01 X23.368Y48.228 F144
(-->Cutting Line)
G01 X22.479Y47.371 F144
(-->Cutting Line)
G01 X22.352Y47.308 F144
(-->Cutting Line)
G01 X20.193Y47.308 F144
(-->Cutting Line)
G01 X20.066Y47.117 F144
(-->Cutting Line)
G01 X19.939Y46.990 F144
(-->Cutting Line)
G01 X19.939Y42.037 F144
(-->Cutting Line)
G01 X20.574Y41.402 F144
(-->Cutting Line)
G01 X21.971Y41.402 F144
(-->Cutting Line)
G01 X22.860Y40.513 F144
(-->Cutting Line)
G01 X22.860Y37.973 F144
(-->Cutting Line)
G01 X23.654Y37.973 F144
(-->Cutting Line)
G01 X23.654Y41.529 F144
(-->Cutting Line)
G01 X22.860Y42.291 F144
(-->Cutting Line)
G01 X22.860Y43.561 F144
(-->Cutting Line)
G01 X21.463Y43.561 F144
(-->Cutting Line)
G01 X21.463Y46.228 F144
(-->Cutting Line)
G01 X22.352Y46.228 F144
(-->Cutting Line)
G01 X22.479Y46.355 F144
(-->Cutting Line)
G01 X22.479Y47.371 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X23.114Y42.164
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X24.384Y42.164 F144
(-->Cutting Line)
G01 X24.384Y44.069 F144
(-->Cutting Line)
G01 X23.749Y44.069 F144
(-->Cutting Line)
G01 X23.368Y44.450 F144
(-->Cutting Line)
G01 X23.368Y46.990 F144
(-->Cutting Line)
G01 X23.590Y47.276 F144
(-->Cutting Line)
G01 X25.654Y47.276 F144
(-->Cutting Line)
G01 X25.908Y46.990 F144
(-->Cutting Line)
G01 X25.908Y43.561 F144
(-->Cutting Line)
G01 X25.908Y42.418 F144
(-->Cutting Line)
G01 X24.448Y41.021 F144
(-->Cutting Line)
G01 X24.448Y37.973 F144
(-->Cutting Line)
G01 X23.654Y37.973 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X24.448Y37.973
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X25.273Y37.973 F144
(-->Cutting Line)
G01 X25.273Y39.878 F144
(-->Cutting Line)
G01 X26.035Y39.878 F144
(-->Cutting Line)
G01 X27.432Y39.878 F144
(-->Cutting Line)
G01 X27.432Y40.640 F144
(-->Cutting Line)
G01 X27.432Y43.561 F144
(-->Cutting Line)
G01 X27.305Y43.561 F144
(-->Cutting Line)
G01 X25.908Y43.561 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X29.464Y44.101
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X27.305Y44.101 F144
(-->Cutting Line)
G01 X27.305Y43.561 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X29.464Y44.101
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X29.464Y41.783 F144
(-->Cutting Line)
G01 X29.845Y41.402 F144
(-->Cutting Line)
G01 X29.845Y40.640 F144
(-->Cutting Line)
G01 X31.369Y40.640 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X27.432Y40.640
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X29.083Y40.640 F144
(-->Cutting Line)
G01 X29.083Y37.846 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X25.273Y37.973
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X25.654Y37.973 F144
(-->Cutting Line)
G01 X26.035Y38.354 F144
(-->Cutting Line)
G01 X26.035Y39.878 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.289Y36.830
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X26.289Y36.163 F144
(-->Cutting Line)
G01 X27.940Y36.163 F144
(-->Cutting Line)
G01 X27.940Y36.957 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.289Y35.941
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X26.289Y35.370 F144
(-->Cutting Line)
G01 X27.940Y35.370 F144
(-->Cutting Line)
G01 X27.940Y36.163 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.416Y34.544
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X28.194Y34.544 F144
(-->Cutting Line)
G01 X28.575Y34.925 F144
(-->Cutting Line)
G01 X30.480Y34.925 F144
(-->Cutting Line)
G01 X30.480Y33.528 F144
(-->Cutting Line)
G01 X28.194Y33.528 F144
(-->Cutting Line)
G01 X28.004Y33.750 F144
(-->Cutting Line)
G01 X26.289Y33.750 F144
(-->Cutting Line)
G01 X26.289Y34.544 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.289Y33.528
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X26.289Y32.956 F144
(-->Cutting Line)
G01 X28.194Y32.956 F144
(-->Cutting Line)
G01 X28.194Y33.528 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X12.446Y44.323
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X12.446Y43.561 F144
(-->Cutting Line)
G01 X14.859Y43.561 F144
(-->Cutting Line)
G01 X15.748Y42.672 F144
(-->Cutting Line)
G01 X18.034Y42.672 F144
(-->Cutting Line)
G01 X18.034Y41.656 F144
(-->Cutting Line)
G01 X19.050Y40.640 F144
(-->Cutting Line)
G01 X21.082Y40.640 F144
(-->Cutting Line)
G01 X21.590Y40.132 F144
(-->Cutting Line)
G01 X22.066Y39.656 F144
(-->Cutting Line)
G01 X22.066Y37.846 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X22.225Y37.973
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X22.860Y37.973 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X21.241Y39.751
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X21.241Y38.100 F144
(-->Cutting Line)
G01 X21.082Y37.973 F144
(-->Cutting Line)
G01 X20.447Y37.973 F144
(-->Cutting Line)
G01 X20.447Y39.497 F144
(-->Cutting Line)
G01 X20.193Y39.751 F144
(-->Cutting Line)
G01 X18.542Y39.751 F144
(-->Cutting Line)
G01 X18.034Y40.259 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X12.319Y39.370
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X8.001Y39.370 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X8.001Y41.910
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X11.811Y41.910 F144
(-->Cutting Line)
G01 X12.573Y41.148 F144
(-->Cutting Line)
G01 X17.526Y41.148 F144
(-->Cutting Line)
G01 X18.034Y41.656 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X8.001Y41.910
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X8.001Y44.323 F144
(-->Cutting Line)
G01 X12.446Y44.323 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X8.001Y41.910
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X8.001Y39.370 F144
(-->Cutting Line)
G01 X8.001Y37.211 F144
(-->Cutting Line)
G01 X11.938Y37.211 F144
(-->Cutting Line)
G01 X12.446Y37.719 F144
(-->Cutting Line)
G01 X19.304Y37.751 F144
(-->Cutting Line)
G01 X19.558Y37.338 F144
(-->Cutting Line)
G01 X19.558Y37.211 F144
(-->Cutting Line)
G01 X19.812Y37.084 F144
(-->Cutting Line)
G01 X21.336Y37.084 F144
(-->Cutting Line)
G01 X22.225Y37.973 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X20.447Y37.973
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X20.066Y37.973 F144
(-->Cutting Line)
G01 X19.558Y38.481 F144
(-->Cutting Line)
G01 X12.319Y38.481 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X19.558Y37.211
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X19.558Y36.957 F144
(-->Cutting Line)
G01 X17.526Y36.957 F144
(-->Cutting Line)
G01 X12.700Y36.449 F144
(-->Cutting Line)
G01 X7.874Y36.449 F144
(-->Cutting Line)
G01 X7.112Y36.449 F144
(-->Cutting Line)
G01 X5.588Y37.973 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X7.874Y36.449
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X7.874Y34.290 F144
(-->Cutting Line)
G01 X12.700Y34.290 F144
(-->Cutting Line)
G01 X12.700Y36.449 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X7.874Y34.290
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X7.874Y31.750 F144
(-->Cutting Line)
G01 X12.700Y31.750 F144
(-->Cutting Line)
G01 X12.700Y34.290 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X7.874Y29.210
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X14.732Y29.210 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X17.526Y36.957
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X17.526Y36.132 F144
(-->Cutting Line)
G01 X21.717Y36.132 F144
(-->Cutting Line)
G01 X22.606Y37.084 F144
(-->Cutting Line)
G01 X26.289Y37.084 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X19.272Y35.338
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X19.304Y34.544 F144
(-->Cutting Line)
G01 X17.780Y34.544 F144
(-->Cutting Line)
G01 X17.653Y34.417 F144
(-->Cutting Line)
G01 X17.653Y33.750 F144
(-->Cutting Line)
G01 X21.082Y33.750 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X19.272Y35.338
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X17.304Y35.338 F144
(-->Cutting Line)
G01 X14.732Y32.766 F144
(-->Cutting Line)
G01 X14.732Y29.210 F144
(-->Cutting Line)
G01 X14.732Y27.432 F144
(-->Cutting Line)
G01 X11.557Y24.257 F144
(-->Cutting Line)
G01 X5.715Y24.257 F144
(-->Cutting Line)
G01 X3.556Y22.098 F144
(-->Cutting Line)
G01 X3.556Y8.763 F144
(-->Cutting Line)
G01 X5.080Y7.239 F144
(-->Cutting Line)
G01 X5.080Y5.334 F144
(-->Cutting Line)
G01 X5.080Y2.667 F144
(-->Cutting Line)
G01 X5.588Y2.159 F144
(-->Cutting Line)
G01 X9.017Y2.159 F144
(-->Cutting Line)
G01 X10.414Y3.556 F144
(-->Cutting Line)
G01 X10.414Y5.334 F144
(-->Cutting Line)
G01 X8.509Y5.334 F144
(-->Cutting Line)
G01 X7.874Y4.699 F144
(-->Cutting Line)
G01 X7.874Y3.302 F144
(-->Cutting Line)
G01 X7.620Y3.048 F144
(-->Cutting Line)
G01 X6.096Y3.048 F144
(-->Cutting Line)
G01 X5.842Y3.302 F144
(-->Cutting Line)
G01 X5.842Y5.334 F144
(-->Cutting Line)
G01 X5.842Y8.128 F144
(-->Cutting Line)
G01 X4.572Y9.398 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X17.653Y32.956
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X19.558Y32.956 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.289Y32.163
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X28.575Y32.163 F144
(-->Cutting Line)
G01 X28.956Y31.750 F144
(-->Cutting Line)
G01 X28.956Y28.702 F144
(-->Cutting Line)
G01 X29.210Y28.448 F144
(-->Cutting Line)
G01 X31.496Y28.448 F144
(-->Cutting Line)
G01 X32.004Y27.940 F144
(-->Cutting Line)
G01 X32.004Y25.400 F144
(-->Cutting Line)
G01 X32.004Y19.050 F144
(-->Cutting Line)
G01 X28.829Y15.875 F144
(-->Cutting Line)
G01 X28.829Y8.128 F144
(-->Cutting Line)
G01 X28.321Y7.620 F144
(-->Cutting Line)
G01 X28.321Y2.413 F144
(-->Cutting Line)
G01 X28.448Y2.286 F144
(-->Cutting Line)
G01 X30.353Y2.286 F144
(-->Cutting Line)
G01 X30.480Y2.413 F144
(-->Cutting Line)
G01 X30.480Y7.620 F144
(-->Cutting Line)
G01 X29.972Y8.128 F144
(-->Cutting Line)
G01 X29.972Y15.113 F144
(-->Cutting Line)
G01 X33.274Y18.415 F144
(-->Cutting Line)
G01 X33.274Y30.861 F144
(-->Cutting Line)
G01 X30.607Y33.528 F144
(-->Cutting Line)
G01 X30.480Y33.528 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.289Y32.956
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X21.939Y32.956 F144
(-->Cutting Line)
G01 X21.082Y33.750 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X5.588Y25.527
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X2.540Y22.479 F144
(-->Cutting Line)
G01 X2.540Y5.334 F144
(-->Cutting Line)
G01 X5.080Y5.334 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X5.842Y5.334
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X7.239Y5.334 F144
(-->Cutting Line)
G01 X7.620Y5.715 F144
(-->Cutting Line)
G01 X7.620Y7.239 F144
(-->Cutting Line)
G01 X6.985Y7.874 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X11.938Y13.335
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X11.938Y17.145 F144
(-->Cutting Line)
G01 X13.081Y18.288 F144
(-->Cutting Line)
G01 X18.542Y18.288 F144
(-->Cutting Line)
G01 X23.114Y18.288 F144
(-->Cutting Line)
G01 X24.384Y19.558 F144
(-->Cutting Line)
G01 X24.384Y25.019 F144
(-->Cutting Line)
G01 X26.035Y26.670 F144
(-->Cutting Line)
G01 X27.813Y28.448 F144
(-->Cutting Line)
G01 X29.210Y28.448 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X17.653Y32.956
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X17.653Y32.163 F144
(-->Cutting Line)
G01 X17.653Y31.115 F144
(-->Cutting Line)
G01 X19.558Y31.115 F144
(-->Cutting Line)
G01 X19.558Y32.163 F144
(-->Cutting Line)
G01 X19.558Y32.956 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X19.558Y32.163
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X17.653Y32.163 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.289Y32.163
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X26.289Y31.115 F144
(-->Cutting Line)
G01 X27.940Y31.115 F144
(-->Cutting Line)
G01 X27.940Y30.099 F144
(-->Cutting Line)
G01 X22.352Y24.511 F144
(-->Cutting Line)
G01 X22.352Y21.717 F144
(-->Cutting Line)
G01 X19.939Y19.304 F144
(-->Cutting Line)
G01 X12.446Y19.304 F144
(-->Cutting Line)
G01 X10.795Y17.653 F144
(-->Cutting Line)
G01 X10.795Y13.843 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X8.382Y5.334
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X8.382Y5.715 F144
(-->Cutting Line)
G01 X8.255Y5.842 F144
(-->Cutting Line)
G01 X8.255Y8.890 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X10.414Y5.334
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X10.922Y5.842 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X16.256Y2.286
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X18.542Y2.286 F144
(-->Cutting Line)
G01 X18.542Y18.288 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X16.256Y2.286
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X16.256Y5.842 F144
(-->Cutting Line)
G01 X16.256Y9.017 F144
(-->Cutting Line)
G01 X11.938Y13.335 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X28.321Y25.019
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X28.321Y19.812 F144
(-->Cutting Line)
G01 X26.162Y19.812 F144
(-->Cutting Line)
G01 X26.162Y26.543 F144
(-->Cutting Line)
G01 X26.035Y26.670 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X28.321Y25.019
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X28.702Y25.400 F144
(-->Cutting Line)
G01 X32.004Y25.400 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X19.558Y31.115
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X19.558Y29.464 F144
(-->Cutting Line)
G01 X20.479Y29.464 F144
(-->Cutting Line)
G01 X22.066Y29.464 F144
(-->Cutting Line)
G01 X22.860Y29.464 F144
(-->Cutting Line)
G01 X23.654Y29.464 F144
(-->Cutting Line)
G01 X23.654Y31.115 F144
(-->Cutting Line)
G01 X22.860Y31.115 F144
(-->Cutting Line)
G01 X22.066Y31.115 F144
(-->Cutting Line)
G01 X20.479Y31.115 F144
(-->Cutting Line)
G01 X19.558Y31.115 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X20.479Y31.115
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X20.479Y29.464 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X21.241Y30.988
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X21.241Y29.591 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X22.066Y31.115
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X22.066Y29.464 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X22.860Y31.115
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X22.860Y29.464 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X23.654Y31.115
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X24.448Y31.115 F144
(-->Cutting Line)
G01 X25.241Y31.115 F144
(-->Cutting Line)
G01 X26.289Y31.115 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X25.241Y31.115
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X25.241Y28.448 F144
(-->Cutting Line)
G01 X24.257Y27.432 F144
(-->Cutting Line)
G01 X20.955Y27.432 F144
(-->Cutting Line)
G01 X20.320Y26.797 F144
(-->Cutting Line)
G01 X20.320Y21.844 F144
(-->Cutting Line)
G01 X18.796Y20.320 F144
(-->Cutting Line)
G01 X10.033Y20.320 F144
(-->Cutting Line)
G01 X8.890Y19.177 F144
(-->Cutting Line)
G01 X8.890Y9.652 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X24.448Y31.115
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X24.448Y28.829 F144
(-->Cutting Line)
G01 X24.067Y28.448 F144
(-->Cutting Line)
G01 X19.431Y28.448 F144
(-->Cutting Line)
G01 X18.288Y27.305 F144
(-->Cutting Line)
G01 X18.288Y21.844 F144
(-->Cutting Line)
G01 X17.907Y21.209 F144
(-->Cutting Line)
G01 X16.129Y21.209 F144
(-->Cutting Line)
G01 X6.731Y21.209 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X16.129Y21.209
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X16.129Y27.813 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X18.796Y47.371
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X19.812Y47.371 F144
(-->Cutting Line)
G01 X20.066Y47.117 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X17.780Y29.464
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X19.558Y29.464 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X26.289Y31.115
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X26.289Y29.845 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X17.780Y29.464
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X16.129Y27.813 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X6.731Y21.209
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X4.572Y19.050 F144
(-->Cutting Line)
G01 X4.572Y18.161 F144
(-->Cutting Line)
G01 X4.572Y9.398 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X21.241Y39.751
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X21.590Y40.132 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X18.034Y40.259
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X12.319Y40.259 F144
(-->Cutting Line)
G01 X12.319Y39.370 F144
(-->Cutting Line)
G01 X12.319Y38.481 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X24.384Y56.388
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X24.003Y56.769 F144
(-->Cutting Line)
G01 X20.828Y56.769 F144
(-->Cutting Line)
G01 X19.050Y56.769 F144
(-->Cutting Line)
G01 X17.272Y56.769 F144
(-->Cutting Line)
G01 X17.272Y56.261 F144
(-->Cutting Line)
G01 X14.954Y56.261 F144
(-->Cutting Line)
G01 X14.192Y55.499 F144
(-->Cutting Line)
G01 X14.192Y52.832 F144
(-->Cutting Line)
G01 X14.224Y52.832 F144
(-->Cutting Line)
G01 X17.526Y52.832 F144
(-->Cutting Line)
G01 X17.526Y48.895 F144
(-->Cutting Line)
G01 X17.145Y48.514 F144
(-->Cutting Line)
G01 X12.319Y48.514 F144
(-->Cutting Line)
G01 X12.319Y46.482 F144
(-->Cutting Line)
G01 X12.319Y46.355 F144
(-->Cutting Line)
G01 X12.446Y46.228 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X14.859Y56.261
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X14.859Y57.277 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X19.050Y56.769
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X19.050Y57.404 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X20.828Y56.769
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X20.828Y57.404 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X20.828Y56.769
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X20.828Y56.134 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X19.050Y56.769
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X19.050Y56.134 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X17.272Y56.261
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X17.272Y55.499 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X12.319Y48.514
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X6.731Y48.514 F144
(-->Cutting Line)
G01 X6.731Y50.165 F144
(-->Cutting Line)
G01 X6.350Y50.546 F144
(-->Cutting Line)
G01 X6.350Y57.658 F144
(-->Cutting Line)
G01 X7.874Y59.182 F144
(-->Cutting Line)
G01 X11.303Y59.182 F144
(-->Cutting Line)
G01 X11.303Y56.007 F144
(-->Cutting Line)
G01 X9.398Y56.007 F144
(-->Cutting Line)
G01 X8.890Y55.499 F144
(-->Cutting Line)
G01 X8.890Y50.546 F144
(-->Cutting Line)
G01 X11.811Y50.546 F144
(-->Cutting Line)
G01 X12.192Y50.927 F144
(-->Cutting Line)
G01 X12.192Y52.832 F144
(-->Cutting Line)
G01 X13.208Y52.832 F144
(-->Cutting Line)
G01 X13.208Y50.673 F144
(-->Cutting Line)
G01 X14.224Y50.673 F144
(-->Cutting Line)
G01 X14.224Y52.832 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X11.303Y56.007
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X13.208Y56.007 F144
(-->Cutting Line)
G01 X13.208Y52.832 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X6.731Y48.514
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X5.588Y48.514 F144
(-->Cutting Line)
G01 X5.461Y48.514 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X5.588Y46.482
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X5.588Y48.514 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X5.588Y46.482
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X8.001Y46.482 F144
(-->Cutting Line)
G01 X12.319Y46.482 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X5.588Y46.482
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X5.588Y37.973 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X8.001Y44.323
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X8.001Y46.482 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X8.255Y8.890
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X8.890Y9.652 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X6.985Y7.874
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X6.985Y18.161 F144
(-->Cutting Line)
G01 X4.572Y18.161 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X10.795Y13.843
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X10.287Y13.843 F144
(-->Cutting Line)
G01 X10.033Y13.589 F144
(-->Cutting Line)
G01 X10.033Y10.160 F144
(-->Cutting Line)
G01 X10.922Y9.271 F144
(-->Cutting Line)
G01 X10.922Y5.842 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X16.256Y5.842
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X10.922Y5.842 F144
(-->next line out of position. Retracting, and repositioning)
G00 Z1.000
G00 X5.588Y25.527
(-->Plunging, then Cutting Line)
G01 Z-0.050 F12
G01 X5.588Y26.924 F144
(-->Cutting Line)
G01 X7.874Y29.210 F144
G00 Z1.000
M05
G04 P4000
G00 X0Y0
