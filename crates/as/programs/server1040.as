.PROGRAM autostart.pc() ; protocol-1040 server: communication task (PC task 1)
  ;
  ; The protocol-1040 server of the Kawasaki FS020N, in AS, written for the fs020n project
  ; from its protocol specification (docs/PROTOCOL.md: requests, commands, reply, timing,
  ; server behaviour). Two programs:
  ;   autostart.pc  this communication task; runs from controller start (PC task 1)
  ;   ros_move      the motion program (robot task 1), started by command 1
  ;
  ; Constants (change them here; the emulator's native server uses the same values):
  ;   .port = 10050        TCP port
  ;   .version = 1040      protocol version the server acts on
  ;   3 s                  accept window (TCP_ACCEPT timeout)
  ;   5 s                  receive timeout (TCP_RECV): no request for 5 s ends the session
  ;   2 s                  send timeout (TCP_SEND): a reply not taken in 2 s ends the session
  ;   16 rows              command ring ros_cmd[0..15, ...]
  ;   128 arguments        most arguments read (255 bytes cannot hold more tokens)
  ;   signal 2007          stops ros_move (its ONI)
  ;   ros_move: CP ON, ACCURACY 10 mm, ACCEL 100 %, DECEL 100 %, SPEED 100 %;
  ;   command 7: 0.5 s time-stamp clamp, 30 % JMOVE when |JT3| or |JT5| < 5 deg,
  ;   else an LMOVE of 0.1 s; step average weight 0.1.
  ;
  ; Globals shared by the two programs:
  ;   ros_srv_run      1 while the server runs
  ;   ros_move_run     1 while ros_move shall loop
  ;   ros_cmd_ind      ring row of the newest request
  ;   ros_cmd[r,0]     command number of row r
  ;   ros_cmd[r,1]     its COUNT_OF_ARGS (at most 128)
  ;   ros_cmd[r,1+k]   its argument k
  ;   ros_speed_limit  written on accept and by command 3, never read
  ;   ros_print        0: quiet (PRINT goes to every terminal: a line per pass would flood
  ;                    them); 1: ros_move prints a line per pass (a trace). Set it here.
  ;
  ; Written for real controllers: names of at most 15 characters, ASCII only, no GOTO out
  ; of a WHILE, every TCP result checked.
  ;
  .port = 10050
  .version = 1040
  ros_print = 0
  ros_srv_run = 1
  ros_move_run = 0
  ; A listening socket left by an earlier run that was aborted would make TCP_LISTEN fail
  ; (E4055): end it first (an error here only means there was none).
  TCP_END_LISTEN .ret, .port
  WHILE ros_srv_run == 1 DO
    ; 1. Stop the motion program, listen, accept within 3 s, stop listening.
    SIGNAL 2007
    .sock = -1
    TCP_LISTEN .ret, .port
    IF .ret < 0 THEN
      ; The port cannot be opened (in use, or no TCP/IP option): say so, try again in 1 s.
      PRINT "autostart.pc: TCP_LISTEN on port ", .port, " failed (", .ret, ")"
      TWAIT 1
    ELSE
      TCP_ACCEPT .sock, .port, 3
      TCP_END_LISTEN .ret, .port
    END
    IF .sock >= 0 THEN
      ; 2. A client: clear the ring (newest = row 0 holding command 0), restart the clock.
      ros_cmd_ind = 0
      ros_cmd[0,0] = 0
      ros_cmd[0,1] = 0
      ros_speed_limit = 1
      TIMER 1 = 0
      TIMER 2 = 0
      .loop = 1
      WHILE .loop == 1 DO
        ; 3. One request: whatever one receive returns (up to 4096 bytes, in 255-byte
        ;    elements); only the first element is parsed.
        .n = 0
        TCP_RECV .ret, .sock, .$buf[1], .n, 5, 255
        IF .ret < 0 THEN
          ; Timeout or a lost connection: the session ends.
          .loop = 0
        END
        IF .loop == 1 THEN
          .$data = .$buf[1]
          ; Tokens: cut before the next blank (mode 0), then cut the run of blanks (mode 1).
          ; A leading blank makes the version token empty: VAL("") = 0, a mismatch.
          .$tok = $DECODE(.$data, " ", 0)
          .ver = VAL(.$tok)
          .$tok = $DECODE(.$data, " ", 1)
          .$tok = $DECODE(.$data, " ", 0)
          .cmd = VAL(.$tok)
          .$tok = $DECODE(.$data, " ", 1)
          .$tok = $DECODE(.$data, " ", 0)
          .cnt = VAL(.$tok)
          IF .ver == .version THEN
            IF .cnt > 128 THEN
              .cnt = 128
            END
            ; Store the request in the ring row after the newest.
            .row = ros_cmd_ind + 1
            IF .row > 15 THEN
              .row = 0
            END
            ros_cmd[.row,0] = .cmd
            ros_cmd[.row,1] = .cnt
            .arg1 = 0
            FOR .i = 1 TO .cnt
              .$tok = $DECODE(.$data, " ", 1)
              .$tok = $DECODE(.$data, " ", 0)
              ros_cmd[.row,.i+1] = VAL(.$tok)
              IF .i == 1 THEN
                .arg1 = ros_cmd[.row,2]
              END
            END
            ; Act.
            CASE .cmd OF
              VALUE 1:
                ; Start ros_move: the server's own test, then MC EXECUTE (which the
                ; controller may still refuse, e.g. while ros_move is paused or finishing).
                IF SWITCH(POWER) AND SWITCH(RUN) AND SWITCH(REPEAT) AND NOT SWITCH(TEACH_LOCK) THEN
                  IF TASK(1) <> 1 AND ERROR == 0 THEN
                    ros_move_run = 1
                    MC EXECUTE ros_move
                  END
                END
              VALUE 2:
                ; Stop ros_move: the loop ends at its next pass (the motion in progress
                ; finishes: TASK(1) = 3), and its ONI on signal 2007 stops the robot once the
                ; signal has been on for 50 ms.
                SIGNAL 2007
                ros_move_run = 0
              VALUE 3:
                ; Monitor speed, and speed = min(program, monitor) from now on.
                ros_speed_limit = .arg1/100
                MC SPEED .arg1
                ABS.SPEED ON
              VALUE 5:
                ; Cancel the current motion, unless the newest request is already a 5:
                ; publish this one first, then BRAKE.
                IF ros_cmd[ros_cmd_ind,0] <> 5 THEN
                  ros_cmd_ind = .row
                  BRAKE
                END
              VALUE 255:
                ; End the session after the reply.
                .loop = 0
            END
            ; Publish the request as the newest.
            ros_cmd_ind = .row
          END
          ; The reply: status, TIMER(1) and the joints from the encoders.
          DECOMPOSE .jt[1] = #HERE
          .$data = $ENCODE(.version, ERROR, SWITCH(RUN), SWITCH(REPEAT), SWITCH(TEACH_LOCK), SWITCH(POWER), TASK(1) == 1)
          .$buf[1] = .$data+$ENCODE(/F10.3, TIMER(1), .jt[1], .jt[2], .jt[3], .jt[4], .jt[5], .jt[6])+" "
          TCP_SEND .ret, .sock, .$buf[1], 1, 2
          IF .ret < 0 THEN
            .loop = 0
          END
        END
      END
      ; 5. Stop the motion program (its ONI stops the robot at once), close, listen again.
      SIGNAL 2007
      TCP_CLOSE .ret, .sock
      PRINT "session closed (", .ret, ")"
    END
  END
.END
.PROGRAM ros_move() ; protocol-1040 server: motion program (robot task 1)
  ; Started by command 1. Stopped by signal 2007 (command 2, 255, timeouts, a lost
  ; connection): its ONI stops the motion at once and ends the program, also while the
  ; last motion finishes after the loop ended (command 2 also ends the loop).
  SIGNAL -2007
  ONI 2007 GOTO stopped
  CP ON
  ACCURACY 10 ALWAYS
  ACCEL 100 ALWAYS
  DECEL 100 ALWAYS
  SPEED 100 ALWAYS
  ; Remember the current joints: a first 7 whose point is where the robot stands moves
  ; nothing.
  DECOMPOSE .prev[1] = #HERE
  .step = 0
  .last_tm = TIMER(2)
  WHILE ros_move_run == 1 DO
    .tm = TIMER(2)
    ; Only the newest request counts. Its COUNT arguments are copied into .arg; the other
    ; entries of .arg keep what earlier passes left there (a request with fewer arguments
    ; uses stale ones; one never assigned stops the program with E0102).
    .ind = ros_cmd_ind
    .cmd = ros_cmd[.ind,0]
    .cnt = ros_cmd[.ind,1]
    FOR .i = 1 TO .cnt
      .arg[.i] = ros_cmd[.ind,.i+1]
    END
    IF .cmd == 6 THEN
      ; Joint move to ARG4..ARG9 (re-issued every pass; once there it moves nothing).
      JMOVE #PPOINT(.arg[4], .arg[5], .arg[6], .arg[7], .arg[8], .arg[9])
    END
    IF .cmd == 7 THEN
      ; Streamed move: extrapolate the sample (position, velocity, acceleration) from its
      ; time stamp ARG1 to now plus ARG2 passes.
      .dt = .tm-.arg[1]
      IF .dt > 0.5 THEN
        .dt = 0.5
      END
      IF .dt < -0.5 THEN
        .dt = -0.5
      END
      .dt = .dt+.arg[2]*.step
      .moved = FALSE
      FOR .i = 1 TO 6
        .pt[.i] = .arg[3+.i]+.dt*.arg[9+.i]+0.5*.dt*.dt*.arg[15+.i]
        IF .pt[.i] <> .prev[.i] THEN
          .moved = TRUE
        END
        .prev[.i] = .pt[.i]
      END
      IF .moved THEN
        IF ABS(.pt[3]) < 5 OR ABS(.pt[5]) < 5 THEN
          ; Near the elbow or wrist singularity: a slow joint move.
          SPEED 30
          JMOVE #PPOINT(.pt[1], .pt[2], .pt[3], .pt[4], .pt[5], .pt[6])
        ELSE
          SPEED 0.1 S
          LMOVE #PPOINT(.pt[1], .pt[2], .pt[3], .pt[4], .pt[5], .pt[6])
        END
      END
    END
    ; The motion instruction has been accepted (the look-ahead wait is over): average the
    ; time from the end of the previous pass to the start of this one (the loop overhead).
    .step = 0.9*.step+0.1*(.tm-.last_tm)
    .last_tm = TIMER(2)
    IF ros_print == 1 THEN
      PRINT "ros_move: cmd ", /I3, .cmd, " step ", /F6.4, .step
    END
  END
stopped:
  ; The ONI stopped the robot at once; the program ends.
.END
