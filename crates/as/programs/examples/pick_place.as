.PROGRAM autostart.pc() ; pick and place: the reporting task (PC task 1)
  ;
  ; An example of a program as people write it: a robot program that picks a part when a
  ; sensor says one is there and places it, and a PC program that starts it and reports each
  ; part placed to a PC over TCP. docs/AS.md shows how it is tested from Rust and the CLI.
  ;
  ; Wiring (change it here):
  ;   input 1001     part present at the pick station (the robot waits for it)
  ;   outputs 1, 2   hand 1: open, close (OPENI/CLOSEI; the emulator's Config::hands)
  ;   port 10060     a PC connects here and reads one line per part: "PLACED n"
  ;
  ; Globals shared by the two programs:
  ;   pp_placed      parts placed since the start
  ;
  .port = 10060
  pp_placed = 0
  MC EXECUTE pick.place
  TCP_END_LISTEN .ret, .port
  WHILE TRUE DO
    TCP_LISTEN .ret, .port
    TCP_ACCEPT .sock, .port, 60
    TCP_END_LISTEN .ret, .port
    IF .sock >= 0 THEN
      .sent = pp_placed
      WHILE .sock >= 0 DO
        IF pp_placed > .sent THEN
          .sent = .sent + 1
          .$out[1] = $ENCODE("PLACED", .sent) + $CHR(13) + $CHR(10)
          TCP_SEND .ret, .sock, .$out[1], 1, 5
          IF .ret < 0 THEN
            TCP_CLOSE .ret, .sock
            .sock = -1
          END
        ELSE
          TWAIT 0.05
        END
      END
    END
  END
.END
.PROGRAM pick.place() ; pick and place: the robot program (robot task 1)
  TOOL gripper
  BASE pedestal
  SPEED 100 ALWAYS
  ACCURACY 1 ALWAYS
  OPENI
  JMOVE #safe
  WHILE TRUE DO
    ; Wait for a part, pick it.
    SWAIT 1001
    APPRO pick, 100
    SPEED 200 MM/S
    LMOVE pick
    CLOSEI
    TWAIT 0.2
    LDEPART 100
    ; Place it.
    APPRO place, 100
    SPEED 200 MM/S
    LMOVE place
    OPENI
    TWAIT 0.2
    LDEPART 100
    pp_placed = pp_placed + 1
    PRINT "placed part ", pp_placed
  END
.END
.JOINTS
#safe 0 0 -90 0 -90 0
.END
.TRANS
gripper 0 0 120 0 0 0
pedestal 0 0 200 0 0 0
pick 900 300 800 0 180 0
place 900 -300 800 0 180 0
.END
