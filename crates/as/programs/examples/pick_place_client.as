.PROGRAM autostart.pc() ; pick and place for a PC server: the reporting task (PC task 1)
  ;
  ; The robot is the client: it connects to the cell PC (192.168.0.10, port 48200), says
  ; READY, and for every line "PICK" it receives the robot program moves one part; this task
  ; then answers "PLACED n" (n: parts placed since the start). "QUIT" ends the work: "BYE",
  ; and the connection closes. A PC not there yet is tried again every second.
  ;
  ; Wiring (change it here):
  ;   outputs 1, 2   hand 1: open, close (OPENI/CLOSEI)
  ;
  ; Globals shared by the two programs:
  ;   pc_todo        parts asked for and not placed yet
  ;   pc_placed      parts placed since the start
  ;
  .ip[1] = 192
  .ip[2] = 168
  .ip[3] = 0
  .ip[4] = 10
  .port = 48200
  .$crlf = $CHR(13) + $CHR(10)
  pc_todo = 0
  pc_placed = 0
  MC EXECUTE pick.client
  .sock = -1
  WHILE .sock < 0 DO
    TCP_CONNECT .sock, .port, .ip[1], 5
    IF .sock < 0 THEN
      PRINT "the PC does not answer (", .sock, "): trying again"
      TWAIT 1
    END
  END
  .$out[1] = "READY" + .$crlf
  TCP_SEND .ret, .sock, .$out[1], 1, 5
  .sent = 0
  .run = TRUE
  WHILE .run DO
    TCP_RECV .ret, .sock, .$in[1], .n, 0.1
    IF .ret == 0 THEN
      .$line = .$in[1]
      .$cmd = $DECODE(.$line, " " + .$crlf, 0)
      IF .$cmd == "PICK" THEN
        pc_todo = pc_todo + 1
      END
      IF .$cmd == "QUIT" THEN
        .run = FALSE
      END
    ELSE
      IF .ret <> -34024 THEN
        ; Not a timeout: the PC closed the connection.
        .run = FALSE
      END
    END
    WHILE pc_placed > .sent DO
      .sent = .sent + 1
      .$out[1] = $ENCODE("PLACED", .sent) + .$crlf
      TCP_SEND .ret, .sock, .$out[1], 1, 5
    END
  END
  .$out[1] = "BYE" + .$crlf
  TCP_SEND .ret, .sock, .$out[1], 1, 5
  TCP_CLOSE .ret, .sock
.END
.PROGRAM pick.client() ; pick and place for a PC server: the robot program (robot task 1)
  TOOL gripper
  BASE pedestal
  SPEED 100 ALWAYS
  ACCURACY 1 ALWAYS
  OPENI
  JMOVE #safe
  WHILE TRUE DO
    WAIT pc_todo > 0
    ; Pick.
    APPRO pick, 100
    SPEED 500 MM/S
    LMOVE pick
    CLOSEI
    TWAIT 0.1
    LDEPART 100
    ; Place.
    APPRO place, 100
    SPEED 500 MM/S
    LMOVE place
    OPENI
    TWAIT 0.1
    LDEPART 100
    pc_todo = pc_todo - 1
    pc_placed = pc_placed + 1
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
