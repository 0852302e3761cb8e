.PROGRAM autostart.pc() ; two servers: commands on port 9111 (PC task 1)
  ;
  ; A PC sends one command a line on port 9111 and gets "OK" or "ERR": "SPEED n" sets the
  ; monitor speed, "OUT n" and "OFF n" switch an output, "COUNT" answers the commands so far.
  ; Port 9112 (autostart2.pc) sends the state every 0.1 s to whoever connects.
  ;
  ; Globals shared by the two programs:
  ;   tp_count       commands handled since the start
  ;
  .port = 9111
  .$crlf = $CHR(13) + $CHR(10)
  tp_count = 0
  TCP_LISTEN .ret, .port
  WHILE TRUE DO
    TCP_ACCEPT .sock, .port, 60
    WHILE .sock >= 0 DO
      TCP_RECV .ret, .sock, .$in[1], .n, 60
      IF .ret < 0 THEN
        TCP_CLOSE .ret, .sock
        .sock = -1
      ELSE
        .$line = .$in[1]
        .$cmd = $DECODE(.$line, " " + .$crlf, 0)
        .arg = VAL(.$line)
        .$reply = "OK"
        tp_count = tp_count + 1
        IF .$cmd == "SPEED" THEN
          MC SPEED .arg
        ELSE
          IF .$cmd == "OUT" THEN
            SIGNAL .arg
          ELSE
            IF .$cmd == "OFF" THEN
              SIGNAL -.arg
            ELSE
              IF .$cmd == "COUNT" THEN
                .$reply = $ENCODE("OK", tp_count)
              ELSE
                .$reply = "ERR"
              END
            END
          END
        END
        .$out[1] = .$reply + .$crlf
        TCP_SEND .ret, .sock, .$out[1], 1, 5
      END
    END
  END
.END
.PROGRAM autostart2.pc() ; two servers: state on port 9112 (PC task 2)
  .port = 9112
  .$crlf = $CHR(13) + $CHR(10)
  TCP_LISTEN .ret, .port
  WHILE TRUE DO
    TCP_ACCEPT .sock, .port, 60
    WHILE .sock >= 0 DO
      .$out[1] = $ENCODE("STATE", tp_count, SIG(1), SIG(2)) + .$crlf
      TCP_SEND .ret, .sock, .$out[1], 1, 5
      IF .ret < 0 THEN
        TCP_CLOSE .ret, .sock
        .sock = -1
      ELSE
        TWAIT 0.1
      END
    END
  END
.END
