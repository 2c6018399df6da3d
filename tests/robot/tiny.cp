% A small payload task for exhaustive tests: two robots hold a payload of length 2 on a 4 x 5
% grid (x 0..3, y 0..4) and carry it from x = 0 to x = 3, one cell per robot per step (either robot may stay).
% The geometry comes from a scene written by the test (obstacles at random), and the domain
% leaves all of it to the continuous check: no collision/4 laws, so every kind of violation
% (effector and payload collisions, reach, payload length) reaches the refinement loop.

:- macros
  minX -> 0; maxX -> 3;
  minY -> 0; maxY -> 4;
  linklengthsq -> 4;
  tolerance -> 1;
  horizon -> 5.

:- sorts
  robot; end; direction; xcoord; ycoord.

:- objects
  r1, r2                  :: robot;
  pl1, pl2                :: end;
  up, down, left, right   :: direction;
  minX..maxX              :: xcoord;
  minY..maxY              :: ycoord.

:- variables
  R                       :: robot;
  P                       :: end;
  D, D1                   :: direction;
  X, X1, X2               :: xcoord;
  Y, Y1, Y2               :: ycoord.

:- constants
  xpos(robot)             :: inertialFluent(xcoord);
  ypos(robot)             :: inertialFluent(ycoord);
  xpay(end)               :: inertialFluent(xcoord);
  ypay(end)               :: inertialFluent(ycoord);
  on(robot,end)           :: sdFluent;
  move(robot,direction)   :: exogenousAction.

move(R,right) causes xpos(R)=X2 if xpos(R)=X1 where X2 = X1+1.
move(R,left)  causes xpos(R)=X2 if xpos(R)=X1 where X2 = X1-1.
move(R,up)    causes ypos(R)=Y2 if ypos(R)=Y1 where Y2 = Y1+1.
move(R,down)  causes ypos(R)=Y2 if ypos(R)=Y1 where Y2 = Y1-1.

nonexecutable move(R,right) if xpos(R)=maxX.
nonexecutable move(R,left)  if xpos(R)=minX.
nonexecutable move(R,up)    if ypos(R)=maxY.
nonexecutable move(R,down)  if ypos(R)=minY.
nonexecutable move(R,D) & move(R,D1) where D @< D1.

caused on(R,P) if xpos(R)=xpay(P) & ypos(R)=ypay(P).
default -on(R,P).
caused xpay(P)=X if on(R,P) & xpos(R)=X.
caused ypay(P)=Y if on(R,P) & ypos(R)=Y.
caused false if -on(R,P) after on(R,P).
caused false if on(r1,P) & on(r2,P).

caused false if xpay(pl1)=X1 & xpay(pl2)=X2 & ypay(pl1)=Y1 & ypay(pl2)=Y2
  where (X2-X1)*(X2-X1)+(Y2-Y1)*(Y2-Y1) < linklengthsq-tolerance ++
        (X2-X1)*(X2-X1)+(Y2-Y1)*(Y2-Y1) > linklengthsq+tolerance.

:- query
  label :: 0;
  maxstep :: 0..horizon;
  0: xpos(r1)=0, ypos(r1)=0, xpos(r2)=0, ypos(r2)=2,
     xpay(pl1)=0, ypay(pl1)=0, xpay(pl2)=0, ypay(pl2)=2;
  maxstep: xpay(pl1)=3, ypay(pl1)=0, xpay(pl2)=3, ypay(pl2)=2.
