$I  ; View build info
$G  ; View G-code parser state
$$  ; View current settings
?  ; View current status

M8  ; Turn on fan
G90  ; Set absolute distance mode
G21  ; Set all units in millimeters

G00 Z5.000000
G00 X274.697210 Y30.874980

M03 S700  ; Turn laser on

G02 X274.184715 Y30.541697 Z-0.125000 I-0.862823 J0.766100 F800
G03 X273.901090 Y30.441780 Z-0.125000 I1.510632 J-4.740599
G00 Z5.000000

(End cutting path id: path1492)


(Start cutting path id: path1483)
(Change tool to Default tool)

G00 Z5.000000
G00 X280.968040 Y30.519310

G01 Z-0.125000 F100.0(Penetrate)
G02 X280.817076 Y30.522882 Z-0.125000 I-0.073719 J0.076288 F800
G02 X280.794040 Y30.606310 Z-0.125000 I0.067485 J0.063528
G00 Z5.000000

(End cutting path id: path1483)


(Start cutting path id: path1481)
(Change tool to Default tool)

G00 Z5.000000
G00 X280.814640 Y30.027030

G01 Z-0.125000 F100.0(Penetrate)
G02 X280.693803 Y28.816721 Z-0.125000 I-40.260449 J3.408410 F800
G03 X280.704030 Y27.967290 Z-0.125000 I3.341902 J-0.384541
G00 Z5.000000

(End cutting path id: path1481)


(Start cutting path id: path1479)
(Change tool to Default tool)

G00 Z5.000000
G00 X282.709350 Y29.825770

G01 Z-0.125000 F100.0(Penetrate)
G03 X282.159642 Y28.708163 Z-0.125000 I0.772784 J-1.074097 F800
G03 X283.231620 Y27.634230 Z-0.125000 I1.110538 J0.036537
G03 X284.085339 Y28.985348 Z-0.125000 I-0.015886 J0.955313
G03 X283.299620 Y30.143350 Z-0.125000 I-3.785698 J-1.723083
G03 X282.697021 Y30.327570 Z-0.125000 I-0.485311 J-0.509808
G03 X282.010490 Y30.046550 Z-0.125000 I0.281815 J-1.667577
G00 Z5.000000

(End cutting path id: path1479)


(Start cutting path id: path1475)
(Change tool to Default tool)

G00 Z5.000000
G00 X279.837530 Y30.426980

G01 Z-0.125000 F100.0(Penetrate)
G03 X277.672434 Y29.754083 Z-0.125000 I-0.377360 J-2.605444 F800
G03 X277.438684 Y28.929261 Z-0.125000 I0.558586 J-0.603833
G03 X278.095330 Y28.242912 Z-0.125000 I0.969718 J0.270462
G03 X279.820030 Y28.639350 Z-0.125000 I0.533282 J1.629825
G00 Z5.000000

(End cutting path id: path1475)


(Start cutting path id: path1473)
(Change tool to Default tool)

G00 Z5.000000
G00 X275.766270 Y29.875100

G01 Z-0.125000 F100.0(Penetrate)
G02 X276.399758 Y28.964503 Z-0.125000 I0.092830 J-0.611072 F800
G03 X276.353780 Y27.927740 Z-0.125000 I1.019128 J-0.564597
G02 X276.664974 Y30.270425 Z-0.125000 I5.509992 J0.460084
G02 X277.717870 Y30.655560 Z-0.125000 I0.688022 J-0.249148
G00 Z5.000000

(End cutting path id: path1473)


(Start cutting path id: path1471)
(Change tool to Default tool)

G00 Z5.000000
G00 X273.111960 Y29.542770

G01 Z-0.125000 F100.0(Penetrate)
G03 X273.129484 Y28.019821 Z-0.125000 I0.843372 J-0.751871 F800
G03 X273.625460 Y27.825580 Z-0.125000 I0.450900 J0.420996
G03 X274.250986 Y28.070687 Z-0.125000 I0.014189 J0.884531
G03 X274.569670 Y28.544610 Z-0.125000 I-0.921296 J0.963623
G03 X274.264326 Y29.417793 Z-0.125000 I-1.132023 J0.094122
G03 X273.111960 Y29.542770 Z-0.125000 I-0.649325 J-0.611923
G01 X273.110589 Y29.547281 Z-0.125000
G02 X274.672830 Y28.706970 Z-0.125000 I0.384879 J-1.156817
G03 X275.117727 Y27.958124 Z-0.125000 I0.906960 J0.032252
G03 X275.451780 Y28.062290 Z-0.125000 I0.120008 J0.202868
G00 Z5.000000

(End cutting path id: path1471)


(Start cutting path id: path1469)
(Change tool to Default tool)

G00 Z5.000000
G00 X266.775980 Y27.435300

G01 Z-0.125000 F100.0(Penetrate)
G03 X268.344977 Y29.263416 Z-0.125000 I-5.408116 J6.228925 F800
G03 X269.517700 Y32.353090 Z-0.125000 I-7.036178 J4.438064
G02 X269.875128 Y30.645324 Z-0.125000 I-8.950005 J-2.764483
G02 X269.996440 Y29.002010 Z-0.125000 I-20.802646 J-2.361823
G03 X271.189356 Y30.190276 Z-0.125000 I-2.216286 J3.417886
G03 X272.781760 Y33.441070 Z-0.125000 I-12.277903 J8.029755
G02 X271.999449 Y28.475320 Z-0.125000 I-15.332993 J-0.128919
G03 X268.875108 Y17.942479 Z-0.125000 I160.121744 J-53.226496
G03 X267.453544 Y8.819285 Z-0.125000 I44.199343 J-11.559429
G03 X269.702350 Y6.085430 Z-0.125000 I2.616314 J-0.139716
G00 Z5.000000

(End cutting path id: path1469)


(Start cutting path id: path1463)
(Change tool to Default tool)

G00 Z5.000000
G00 X282.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X282.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1463)


(Start cutting path id: path1461)
(Change tool to Default tool)

G00 Z5.000000
G00 X281.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X281.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1461)


(Start cutting path id: path1459)
(Change tool to Default tool)

G00 Z5.000000
G00 X280.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X280.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1459)


(Start cutting path id: path1457)
(Change tool to Default tool)

G00 Z5.000000
G00 X279.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X279.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1457)


(Start cutting path id: path1455)
(Change tool to Default tool)

G00 Z5.000000
G00 X278.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X278.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1455)


(Start cutting path id: path1453)
(Change tool to Default tool)

G00 Z5.000000
G00 X277.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X277.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1453)


(Start cutting path id: path1451)
(Change tool to Default tool)

G00 Z5.000000
G00 X276.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X276.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1451)


(Start cutting path id: path1449)
(Change tool to Default tool)

G00 Z5.000000
G00 X275.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X275.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1449)


(Start cutting path id: path1447)
(Change tool to Default tool)

G00 Z5.000000
G00 X274.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X274.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1447)


(Start cutting path id: path1443)
(Change tool to Default tool)

G00 Z5.000000
G00 X272.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X272.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1443)


(Start cutting path id: path1441)
(Change tool to Default tool)

G00 Z5.000000
G00 X271.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X271.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1441)


(Start cutting path id: path1439)
(Change tool to Default tool)

G00 Z5.000000
G00 X270.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X270.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1439)


(Start cutting path id: path1437)
(Change tool to Default tool)

G00 Z5.000000
G00 X269.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X269.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1437)


(Start cutting path id: path1435)
(Change tool to Default tool)

G00 Z5.000000
G00 X268.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X268.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1435)


(Start cutting path id: path1433)
(Change tool to Default tool)

G00 Z5.000000
G00 X267.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X267.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1433)


(Start cutting path id: path1431)
(Change tool to Default tool)

G00 Z5.000000
G00 X266.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X266.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1431)


(Start cutting path id: path1429)
(Change tool to Default tool)

G00 Z5.000000
G00 X265.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X265.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1429)


(Start cutting path id: path1427)
(Change tool to Default tool)

G00 Z5.000000
G00 X264.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X264.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1427)


(Start cutting path id: path1423)
(Change tool to Default tool)

G00 Z5.000000
G00 X262.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X262.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1423)


(Start cutting path id: path1421)
(Change tool to Default tool)

G00 Z5.000000
G00 X261.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X261.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1421)


(Start cutting path id: path1419)
(Change tool to Default tool)

G00 Z5.000000
G00 X260.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X260.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1419)


(Start cutting path id: path1417)
(Change tool to Default tool)

G00 Z5.000000
G00 X259.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X259.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1417)


(Start cutting path id: path1415)
(Change tool to Default tool)

G00 Z5.000000
G00 X258.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X258.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1415)


(Start cutting path id: path1413)
(Change tool to Default tool)

G00 Z5.000000
G00 X257.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X257.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1413)


(Start cutting path id: path1411)
(Change tool to Default tool)

G00 Z5.000000
G00 X256.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X256.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1411)


(Start cutting path id: path1409)
(Change tool to Default tool)

G00 Z5.000000
G00 X255.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X255.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1409)


(Start cutting path id: path1407)
(Change tool to Default tool)

G00 Z5.000000
G00 X254.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X254.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1407)


(Start cutting path id: path1403)
(Change tool to Default tool)

G00 Z5.000000
G00 X252.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X252.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1403)


(Start cutting path id: path1401)
(Change tool to Default tool)

G00 Z5.000000
G00 X251.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X251.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1401)


(Start cutting path id: path1399)
(Change tool to Default tool)

G00 Z5.000000
G00 X250.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X250.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1399)


(Start cutting path id: path1397)
(Change tool to Default tool)

G00 Z5.000000
G00 X249.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X249.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1397)


(Start cutting path id: path1395)
(Change tool to Default tool)

G00 Z5.000000
G00 X248.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X248.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1395)


(Start cutting path id: path1393)
(Change tool to Default tool)

G00 Z5.000000
G00 X247.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X247.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1393)


(Start cutting path id: path1391)
(Change tool to Default tool)

G00 Z5.000000
G00 X246.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X246.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1391)


(Start cutting path id: path1389)
(Change tool to Default tool)

G00 Z5.000000
G00 X245.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X245.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1389)


(Start cutting path id: path1387)
(Change tool to Default tool)

G00 Z5.000000
G00 X244.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X244.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1387)


(Start cutting path id: path1383)
(Change tool to Default tool)

G00 Z5.000000
G00 X242.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X242.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1383)


(Start cutting path id: path1381)
(Change tool to Default tool)

G00 Z5.000000
G00 X241.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X241.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1381)


(Start cutting path id: path1379)
(Change tool to Default tool)

G00 Z5.000000
G00 X240.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X240.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1379)


(Start cutting path id: path1377)
(Change tool to Default tool)

G00 Z5.000000
G00 X239.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X239.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1377)


(Start cutting path id: path1375)
(Change tool to Default tool)

G00 Z5.000000
G00 X238.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X238.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1375)


(Start cutting path id: path1373)
(Change tool to Default tool)

G00 Z5.000000
G00 X237.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X237.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1373)


(Start cutting path id: path1371)
(Change tool to Default tool)

G00 Z5.000000
G00 X236.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X236.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1371)


(Start cutting path id: path1369)
(Change tool to Default tool)

G00 Z5.000000
G00 X235.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X235.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1369)


(Start cutting path id: path1367)
(Change tool to Default tool)

G00 Z5.000000
G00 X234.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X234.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1367)


(Start cutting path id: path1363)
(Change tool to Default tool)

G00 Z5.000000
G00 X232.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X232.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1363)


(Start cutting path id: path1361)
(Change tool to Default tool)

G00 Z5.000000
G00 X231.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X231.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1361)


(Start cutting path id: path1359)
(Change tool to Default tool)

G00 Z5.000000
G00 X230.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X230.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1359)


(Start cutting path id: path1357)
(Change tool to Default tool)

G00 Z5.000000
G00 X229.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X229.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1357)


(Start cutting path id: path1355)
(Change tool to Default tool)

G00 Z5.000000
G00 X228.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X228.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1355)


(Start cutting path id: path1353)
(Change tool to Default tool)

G00 Z5.000000
G00 X227.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X227.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1353)


(Start cutting path id: path1351)
(Change tool to Default tool)

G00 Z5.000000
G00 X226.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X226.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1351)


(Start cutting path id: path1349)
(Change tool to Default tool)

G00 Z5.000000
G00 X225.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X225.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1349)


(Start cutting path id: path1347)
(Change tool to Default tool)

G00 Z5.000000
G00 X224.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X224.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1347)


(Start cutting path id: path1343)
(Change tool to Default tool)

G00 Z5.000000
G00 X222.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X222.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1343)


(Start cutting path id: path1341)
(Change tool to Default tool)

G00 Z5.000000
G00 X221.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X221.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1341)


(Start cutting path id: path1339)
(Change tool to Default tool)

G00 Z5.000000
G00 X220.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X220.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1339)


(Start cutting path id: path1337)
(Change tool to Default tool)

G00 Z5.000000
G00 X219.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X219.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1337)


(Start cutting path id: path1335)
(Change tool to Default tool)

G00 Z5.000000
G00 X218.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X218.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1335)


(Start cutting path id: path1333)
(Change tool to Default tool)

G00 Z5.000000
G00 X217.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X217.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1333)


(Start cutting path id: path1331)
(Change tool to Default tool)

G00 Z5.000000
G00 X216.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X216.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1331)


(Start cutting path id: path1329)
(Change tool to Default tool)

G00 Z5.000000
G00 X215.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X215.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1329)


(Start cutting path id: path1327)
(Change tool to Default tool)

G00 Z5.000000
G00 X214.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X214.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1327)


(Start cutting path id: path1323)
(Change tool to Default tool)

G00 Z5.000000
G00 X212.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X212.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1323)


(Start cutting path id: path1321)
(Change tool to Default tool)

G00 Z5.000000
G00 X211.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X211.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1321)


(Start cutting path id: path1319)
(Change tool to Default tool)

G00 Z5.000000
G00 X210.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X210.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1319)


(Start cutting path id: path1317)
(Change tool to Default tool)

G00 Z5.000000
G00 X209.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X209.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1317)


(Start cutting path id: path1315)
(Change tool to Default tool)

G00 Z5.000000
G00 X208.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X208.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1315)


(Start cutting path id: path1313)
(Change tool to Default tool)

G00 Z5.000000
G00 X207.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X207.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1313)


(Start cutting path id: path1311)
(Change tool to Default tool)

G00 Z5.000000
G00 X206.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X206.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1311)


(Start cutting path id: path1309)
(Change tool to Default tool)

G00 Z5.000000
G00 X205.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X205.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1309)


(Start cutting path id: path1307)
(Change tool to Default tool)

G00 Z5.000000
G00 X204.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X204.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1307)


(Start cutting path id: path1303)
(Change tool to Default tool)

G00 Z5.000000
G00 X202.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X202.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1303)


(Start cutting path id: path1301)
(Change tool to Default tool)

G00 Z5.000000
G00 X201.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X201.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1301)


(Start cutting path id: path1299)
(Change tool to Default tool)

G00 Z5.000000
G00 X200.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X200.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1299)


(Start cutting path id: path1297)
(Change tool to Default tool)

G00 Z5.000000
G00 X199.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X199.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1297)


(Start cutting path id: path1295)
(Change tool to Default tool)

G00 Z5.000000
G00 X198.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X198.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1295)


(Start cutting path id: path1293)
(Change tool to Default tool)

G00 Z5.000000
G00 X197.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X197.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1293)


(Start cutting path id: path1291)
(Change tool to Default tool)

G00 Z5.000000
G00 X196.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X196.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1291)


(Start cutting path id: path1289)
(Change tool to Default tool)

G00 Z5.000000
G00 X195.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X195.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1289)


(Start cutting path id: path1287)
(Change tool to Default tool)

G00 Z5.000000
G00 X194.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X194.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1287)


(Start cutting path id: path1283)
(Change tool to Default tool)

G00 Z5.000000
G00 X192.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X192.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1283)


(Start cutting path id: path1281)
(Change tool to Default tool)

G00 Z5.000000
G00 X191.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X191.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1281)


(Start cutting path id: path1279)
(Change tool to Default tool)

G00 Z5.000000
G00 X190.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X190.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1279)


(Start cutting path id: path1277)
(Change tool to Default tool)

G00 Z5.000000
G00 X189.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X189.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1277)


(Start cutting path id: path1275)
(Change tool to Default tool)

G00 Z5.000000
G00 X188.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X188.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1275)


(Start cutting path id: path1273)
(Change tool to Default tool)

G00 Z5.000000
G00 X187.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X187.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1273)


(Start cutting path id: path1271)
(Change tool to Default tool)

G00 Z5.000000
G00 X186.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X186.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1271)


(Start cutting path id: path1269)
(Change tool to Default tool)

G00 Z5.000000
G00 X185.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X185.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1269)


(Start cutting path id: path1267)
(Change tool to Default tool)

G00 Z5.000000
G00 X184.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X184.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1267)


(Start cutting path id: path1263)
(Change tool to Default tool)

G00 Z5.000000
G00 X182.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X182.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1263)


(Start cutting path id: path1261)
(Change tool to Default tool)

G00 Z5.000000
G00 X181.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X181.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1261)


(Start cutting path id: path1259)
(Change tool to Default tool)

G00 Z5.000000
G00 X180.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X180.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1259)


(Start cutting path id: path1257)
(Change tool to Default tool)

G00 Z5.000000
G00 X179.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X179.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1257)


(Start cutting path id: path1255)
(Change tool to Default tool)

G00 Z5.000000
G00 X178.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X178.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1255)


(Start cutting path id: path1253)
(Change tool to Default tool)

G00 Z5.000000
G00 X177.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X177.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1253)


(Start cutting path id: path1251)
(Change tool to Default tool)

G00 Z5.000000
G00 X176.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X176.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1251)


(Start cutting path id: path1249)
(Change tool to Default tool)

G00 Z5.000000
G00 X175.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X175.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1249)


(Start cutting path id: path1247)
(Change tool to Default tool)

G00 Z5.000000
G00 X174.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X174.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1247)


(Start cutting path id: path1243)
(Change tool to Default tool)

G00 Z5.000000
G00 X172.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X172.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1243)


(Start cutting path id: path1241)
(Change tool to Default tool)

G00 Z5.000000
G00 X171.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X171.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1241)


(Start cutting path id: path1239)
(Change tool to Default tool)

G00 Z5.000000
G00 X170.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X170.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1239)


(Start cutting path id: path1237)
(Change tool to Default tool)

G00 Z5.000000
G00 X169.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X169.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1237)


(Start cutting path id: path1235)
(Change tool to Default tool)

G00 Z5.000000
G00 X168.562498 Y192.669830

G01 Z-0.125000 F100.0(Penetrate)
G01 X168.562498 Y187.669830 Z-0.125000 F800
G00 Z5.000000

(End cutting path id: path1235)


(Start cutting path id: path1233)
(Change tool to Default tool)

G00 Z5.000000
G00 X167.562498 Y192.669830
M30
